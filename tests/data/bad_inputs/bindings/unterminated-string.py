# expect: 3 :2:
STREAMS = {'reach: 1}
