# expect: 3 :2: running it raised MemoryError
blob = bytearray(1 << 42)
