# expect: 3 :2:
def streams(:
    pass
