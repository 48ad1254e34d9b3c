# expect: 3 defines no 'STREAMS'
from llmpas.language.bindings import sampler, test
STREEMS = {}
