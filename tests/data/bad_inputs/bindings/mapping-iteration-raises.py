# expect: 3 :10: reading it raised OSError: device busy
from collections.abc import Mapping

class Odd(Mapping):
    def __getitem__(self, k):
        raise KeyError(k)
    def __len__(self):
        return 1
    def __iter__(self):
        raise OSError('device busy')

STREAMS = Odd()
