# expect: 3 :3:
def f():
return 1
STREAMS = {}
