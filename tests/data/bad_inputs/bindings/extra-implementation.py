# expect: 3 implementation 'teleport' is given but
from llmpas.language.bindings import sampler, test
f = lambda *a: iter(())
STREAMS = {'sample-pose': f, 'test-cfree': f, 'reach': f, 'teleport': f}
