# expect: 3 STREAMS['sample-pose'] is float, not callable
STREAMS = {'sample-pose': 1.5, 'test-cfree': print, 'reach': print}
