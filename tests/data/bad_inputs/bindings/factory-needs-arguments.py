# expect: 3 calling STREAMS() raised TypeError
def STREAMS(robot):
    return {}
