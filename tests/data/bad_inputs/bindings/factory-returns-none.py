# expect: 3 STREAMS is NoneType, not a mapping
def STREAMS():
    pass
