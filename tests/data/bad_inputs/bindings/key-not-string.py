# expect: 3 key 1 is not a stream name
STREAMS = {1: print}
