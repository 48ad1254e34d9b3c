# expect: 3 :3: calling STREAMS() raised RuntimeError: calibration file missing
def STREAMS():
    raise RuntimeError('calibration file missing')
