# expect: 3 STREAMS is list, not a mapping
STREAMS = [('reach', print)]
