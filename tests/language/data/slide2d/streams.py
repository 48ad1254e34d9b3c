"""Streams of the slide2d test problem (``llmpas plan ... --bindings streams.py:STREAMS``).

``VALUES`` gives the poses the problem file names; regions are keyed as the file spells them."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from llmpas.language.bindings import sampler, test

VALUES = {"pA0": np.array([0.0, 0.0]), "pB0": np.array([1.0, 0.0]), "pGoal": np.array([5.0, 0.0])}
REGIONS = {"Left": (0.0, 4.0), "Right": (4.0, 10.0)}
CALLS: list[tuple[str, str]] = []


def sample_pose(b: str, r: str) -> Iterator[tuple[np.ndarray]]:
    CALLS.append((b, r))
    lo, _ = REGIONS[r]  # a KeyError here would mean the region's name was not kept as written
    for x in (lo + 1.0, lo + 3.0, lo + 5.0):  # in Right: 5.0 is pGoal's value, taken by bA
        yield (np.array([x, 0.0]),)


def cfree(b1: str, p1: np.ndarray, b2: str, p2: np.ndarray) -> bool:
    return bool(np.linalg.norm(p1 - p2) >= 1.0)


STREAMS = {"sample-pose": sampler(sample_pose, max_outputs=3), "test-cfree": test(cfree)}
