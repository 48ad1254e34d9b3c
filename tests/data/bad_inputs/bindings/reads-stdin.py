# expect: 3 :2: running it raised EOFError
answer = input('robot id? ')
