"""Geometry of the 2-D domain: a table along x, blocks standing on it, a gripper above it.

Blocks are rectangles (width along x, height along y) standing on the table (y = 0); a pose is
the x of a block's centre. A gripper configuration is a point (x, y): holding a block from above
puts the gripper at the block's top plus a small offset.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

GRIP_OFFSET = 0.1  # gripper height above the top of the block it holds
MARGIN = 1e-6  # tolerance of the containment and overlap tests


@dataclass(frozen=True)
class Pose:
    """Where a block stands: the x of its centre."""

    x: float


@dataclass(frozen=True)
class Conf:
    """A gripper configuration: a point above the table."""

    x: float
    y: float


@dataclass(frozen=True)
class Traj:
    """A piecewise-linear gripper path through ``waypoints``."""

    waypoints: tuple[Conf, ...]

    @property
    def length(self) -> float:
        pts = self.waypoints
        return sum(float(np.hypot(b.x - a.x, b.y - a.y)) for a, b in itertools.pairwise(pts))


@dataclass(frozen=True)
class BlockSpec:
    name: str
    width: float
    height: float

    def footprint(self, pose: Pose) -> tuple[float, float]:
        return pose.x - self.width / 2, pose.x + self.width / 2


@dataclass(frozen=True)
class Interval:
    """A region of the table: ``[lo, hi]`` along x."""

    name: str
    lo: float
    hi: float

    @property
    def width(self) -> float:
        return self.hi - self.lo

    def contains(self, block: BlockSpec, pose: Pose) -> bool:
        lo, hi = block.footprint(pose)
        return self.lo - MARGIN <= lo and hi <= self.hi + MARGIN


@dataclass(frozen=True)
class Scene:
    """One instance: blocks (block i's goal is region i), their start poses, the gripper home."""

    blocks: tuple[BlockSpec, ...]
    regions: tuple[Interval, ...]  # goal regions, one per block, in block order
    table: Interval
    start: tuple[Pose, ...]
    home: Conf
    travel_height: float

    def block(self, name: str) -> BlockSpec:
        for b in self.blocks:
            if b.name == name:
                return b
        raise KeyError(f"unknown block {name!r}")

    def region(self, name: str) -> Interval:
        if name == self.table.name:
            return self.table
        for r in self.regions:
            if r.name == name:
                return r
        raise KeyError(f"unknown region {name!r}")

    def goal_of(self, block: str) -> Interval:
        return self.regions[[b.name for b in self.blocks].index(block)]


def overlap(b1: BlockSpec, p1: Pose, b2: BlockSpec, p2: Pose) -> bool:
    """True when the two footprints share more than a boundary point."""
    lo1, hi1 = b1.footprint(p1)
    lo2, hi2 = b2.footprint(p2)
    return lo1 < hi2 - MARGIN and lo2 < hi1 - MARGIN


# ------------------------------------------------------------------------------ generation


def make_world(n_blocks: int, seed: int) -> Scene:
    """A random instance with ``n_blocks`` blocks; every goal region has room for its block."""
    if n_blocks < 1:
        raise ValueError(f"tamp2d needs at least 1 block, got {n_blocks}")
    rng = np.random.default_rng(seed)
    blocks = tuple(
        BlockSpec(f"b{i + 1}", float(rng.uniform(0.8, 1.2)), float(rng.uniform(0.4, 1.0)))
        for i in range(n_blocks)
    )
    regions, table = _layout(blocks, rng)
    start = _start_poses(blocks, regions, table, rng)
    travel = 2.0 * max(b.height for b in blocks) + 2 * GRIP_OFFSET + 0.2
    return Scene(blocks, regions, table, start, Conf(table.lo, travel), travel)


def _layout(
    blocks: tuple[BlockSpec, ...], rng: np.random.Generator
) -> tuple[tuple[Interval, ...], Interval]:
    """Goal regions in random order along the table, separated by gaps wide enough for any block."""
    widest = max(b.width for b in blocks)
    widths = [b.width * float(rng.uniform(1.3, 1.8)) for b in blocks]
    x = float(rng.uniform(1.0, 1.5)) * widest
    bounds: dict[int, Interval] = {}
    for i in rng.permutation(len(blocks)):
        bounds[int(i)] = Interval(f"r{int(i) + 1}", x, x + widths[int(i)])
        x += widths[int(i)] + float(rng.uniform(1.0, 1.5)) * widest
    regions = tuple(bounds[i] for i in range(len(blocks)))
    return regions, Interval("table", 0.0, x)


def _start_poses(
    blocks: tuple[BlockSpec, ...],
    regions: tuple[Interval, ...],
    table: Interval,
    rng: np.random.Generator,
) -> tuple[Pose, ...]:
    """Non-overlapping start poses, none inside its own goal; about half obstruct another goal."""
    placed: dict[int, Pose] = {}
    for i in (int(j) for j in rng.permutation(len(blocks))):
        others = [r for k, r in enumerate(regions) if k != i]
        aim = others[int(rng.integers(len(others)))] if others and rng.random() < 0.5 else table
        placed[i] = _free_spot(i, aim, blocks, regions[i], placed, table, rng)
    return tuple(placed[i] for i in range(len(blocks)))


def _free_spot(
    i: int,
    aim: Interval,
    blocks: tuple[BlockSpec, ...],
    own_goal: Interval,
    placed: dict[int, Pose],
    table: Interval,
    rng: np.random.Generator,
) -> Pose:
    b = blocks[i]
    for attempt in range(2000):
        where = aim if attempt < 50 else table
        lo, hi = where.lo + b.width / 2, where.hi - b.width / 2
        if hi < lo:
            continue
        p = Pose(float(rng.uniform(lo, hi)))
        clash = any(overlap(b, p, blocks[k], q) for k, q in placed.items())
        if not clash and not own_goal.contains(b, p) and table.contains(b, p):
            return p
    raise RuntimeError("could not place the blocks (the table is too crowded)")
