# expect: 3 :4: running it raised GeneratorExit
import os
STREAMS = {'reach': os.getcwd}
raise GeneratorExit
