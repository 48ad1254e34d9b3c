; expect: 3 :2:1: expected '(define ...)'
import os
os.system('echo pwned')
