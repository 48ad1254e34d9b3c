# expect: 3 :4: running it raised ValueError: p_success must be in [0, 1]
from llmpas.language.bindings import sampler
f = lambda *a: iter(())
STREAMS = {'sample-pose': sampler(f, p_success=2.0), 'test-cfree': f, 'reach': f}
