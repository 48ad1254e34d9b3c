# expect: 3 running it raised RecursionError
def f(n):
    return f(n + 1)

f(0)
