# expect: 3 key '' is not a stream name
STREAMS = {'': print}
