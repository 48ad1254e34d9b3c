# expect: 3 :3: running it raised KeyError
CONFIG = {}
port = CONFIG['port']
