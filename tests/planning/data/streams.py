"""Stream implementations for the place1d test problem (loaded by ``llmpas plan --bindings``)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from llmpas.language.bindings import sampler, test

REGIONS = {"r1": (0.0, 3.0), "r2": (5.0, 9.0)}
NAMED_POSES = {"p0": 0.0, "p1": 1.5}


def _pose(p: object) -> float:
    return NAMED_POSES[p] if isinstance(p, str) else float(p)  # type: ignore[arg-type]


def make_streams(seed: int = 0) -> dict[str, object]:
    rng = np.random.default_rng(seed)

    def sample_pose(b: str, r: str) -> Iterator[tuple[float]]:
        lo, hi = REGIONS[r]
        while True:
            yield (round(float(rng.uniform(lo, hi - 1.0)), 3),)

    def cfree(b1: str, p1: object, b2: str, p2: object) -> bool:
        return abs(_pose(p1) - _pose(p2)) >= 1.0

    def reach(b: str, p: object) -> Iterator[tuple[float]]:
        yield (_pose(p) + 0.5,)

    return {
        "sample-pose": sampler(sample_pose, max_outputs=6),
        "test-cfree": test(cfree),
        "reach": sampler(reach, deferred=True),
    }


STREAMS = make_streams


def _partial() -> dict[str, object]:
    streams = make_streams()
    del streams["reach"]
    return streams


PARTIAL = _partial
