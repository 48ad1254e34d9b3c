# expect: 4 planning did not end within 13 s (--max-time 2): a stream of --bindings
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "planning" / "data"))
from streams import make_streams  # noqa: E402

from llmpas.language.bindings import sampler  # noqa: E402

import time  # noqa: E402


def reach(b, p):
    time.sleep(10**6)  # a driver call that never returns
    yield (1.0,)


STREAMS = {**make_streams(), "reach": sampler(reach)}
