# expect: 3 :3: running it raised ValueError: no robot attached
x = 1
raise ValueError('no robot attached')
