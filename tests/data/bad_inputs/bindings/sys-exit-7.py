# expect: 3 running it called sys.exit(7)
import sys
sys.exit(7)
