"""Instances of the pds-tamp2d domain and the two benchmark families, generated from a seed.

``mirror``: N blocks stand in a row left of a wall at x = 0; each must go to the mirror image of
its start pose (exact goal poses), right of the wall; two robots start at the two ends.

``packed``: N slots in a row, each a little wider than one block and narrower than two; block i
must end in slot i. For N >= 2 the blocks start in the slots permuted by a random cycle, so every
slot is taken and one block must first go to the free ground on the left; for N = 1 the block
starts on the free ground. One robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from llmpas.examples.tamp2d_pds.pds2d_geometry import (
    GRIPPER_HEIGHT,
    Block,
    Conf,
    Pose,
    Rect,
    Region,
)

FAMILIES = ("mirror", "packed")
MAX_BLOCKS = 40


@dataclass(frozen=True)
class Scene:
    """One instance: blocks, their start poses and goals (a pose or a region per block), the
    ground, fixed obstacles, and robots with their home confs (also their goal confs)."""

    family: str
    blocks: tuple[Block, ...]
    start: tuple[Pose, ...]
    goals: tuple[Pose | Region, ...]  # block i's goal: an exact pose or a region to be in
    ground: Region
    regions: tuple[Region, ...]  # regions besides the ground (goal slots)
    obstacles: tuple[Rect, ...]
    robots: tuple[str, ...]
    homes: tuple[Conf, ...]
    carry: float  # height at which grippers travel: above everything a gripper can hang over

    def __post_init__(self) -> None:
        n = len(self.blocks)
        if not (len(self.start) == len(self.goals) == n) or len(self.robots) != len(self.homes):
            raise ValueError("a world needs a start and a goal per block and a home per robot")

    def block(self, name: str) -> Block:
        for b in self.blocks:
            if b.name == name:
                return b
        raise KeyError(f"unknown block {name!r}")

    def region(self, name: str) -> Region:
        for r in (self.ground, *self.regions):
            if r.name == name:
                return r
        raise KeyError(f"unknown region {name!r}")

    @property
    def tallest(self) -> float:
        return max(b.height for b in self.blocks)


def make_world(family: str, n_blocks: int, seed: int) -> Scene:
    """A ``family`` instance with ``n_blocks`` blocks; the same arguments give the same world."""
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}; families are {', '.join(FAMILIES)}")
    if not 1 <= n_blocks <= MAX_BLOCKS:
        raise ValueError(f"the number of blocks must be in 1..{MAX_BLOCKS}, got {n_blocks}")
    rng = np.random.default_rng([seed, FAMILIES.index(family)])
    return _mirror(n_blocks, rng) if family == "mirror" else _packed(n_blocks, rng)


def _blocks(n: int, rng: np.random.Generator, widths: tuple[float, float]) -> tuple[Block, ...]:
    return tuple(
        Block(f"b{i + 1}", float(rng.uniform(*widths)), float(rng.uniform(0.8, 1.4)))
        for i in range(n)
    )


def _carry(blocks: tuple[Block, ...], obstacles: tuple[Rect, ...]) -> float:
    """Travel height: a held block hanging below the gripper clears every block and wall."""
    top = max([b.height for b in blocks] + [o.y1 for o in obstacles])
    hang = max(b.height for b in blocks) + GRIPPER_HEIGHT / 2
    return round(top + hang + 0.5, 3)


def _mirror(n: int, rng: np.random.Generator) -> Scene:
    blocks = _blocks(n, rng, (1.0, 1.6))
    wall = Rect(-0.15, 0.0, 0.15, float(rng.uniform(1.5, 2.0)))
    x = wall.x1 + float(rng.uniform(0.5, 1.0))
    start = []
    for b in blocks:
        start.append(b.resting(-(x + b.width / 2)))
        x += b.width + float(rng.uniform(0.4, 1.0))
    goals = tuple(Pose(-p.x, p.y) for p in start)
    extent = x + 2.0
    ground = Region("ground", -extent, extent)
    carry = _carry(blocks, (wall,))
    homes = (Conf(-extent + 0.5, carry), Conf(extent - 0.5, carry))
    return Scene(
        "mirror", blocks, tuple(start), goals, ground, (), (wall,), ("r0", "r1"), homes, carry
    )


def _packed(n: int, rng: np.random.Generator) -> Scene:
    blocks = _blocks(n, rng, (1.0, 1.3))
    slot_width = 1.3 * float(rng.uniform(1.05, 1.2))  # wider than any block, narrower than two
    buffer = float(rng.uniform(3.0, 4.0)) * slot_width  # free ground left of the slots
    slots = []
    x = buffer
    for i in range(n):
        slots.append(Region(f"s{i + 1}", round(x, 6), round(x + slot_width, 6)))
        x += slot_width + float(rng.uniform(0.05, 0.2))
    ground = Region("ground", 0.0, x + 0.5)
    if n == 1:
        start = [blocks[0].resting(float(rng.uniform(1.0, buffer - 1.0)))]
    else:
        cycle = [int(i) for i in rng.permutation(n)]  # block cycle[k] sits in slot cycle[k+1]
        where = {cycle[k]: cycle[(k + 1) % n] for k in range(n)}
        start = [blocks[i].resting(_centre(slots[where[i]], blocks[i], rng)) for i in range(n)]
    carry = _carry(blocks, ())
    return Scene(
        "packed",
        blocks,
        tuple(start),
        tuple(slots),
        ground,
        tuple(slots),
        (),
        ("r0",),
        (Conf(0.3, carry),),
        carry,
    )


def _centre(slot: Region, block: Block, rng: np.random.Generator) -> float:
    room = (slot.hi - slot.lo - block.width) / 2
    return (slot.lo + slot.hi) / 2 + float(rng.uniform(-room, room)) * 0.5


__all__ = ["FAMILIES", "MAX_BLOCKS", "Scene", "make_world"]
