# expect: 3 STREAMS is str, not a mapping
STREAMS = 'reach'
