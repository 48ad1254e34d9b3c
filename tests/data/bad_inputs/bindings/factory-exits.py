# expect: 3 calling STREAMS() called sys.exit(3)
import sys

def STREAMS():
    sys.exit(3)
