"""Python implementations of the pds-tamp2d streams, bound by name to ``stream.pddl``.

Every stream is a plain function of the :class:`Scene` (and a seeded rng for samplers): poses
and grasps are sampled, IK and motions are computed and collision-checked against the fixed
obstacles (the streams do not see where movable blocks are: that is the planner's ``CFree``).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator
from functools import partial
from typing import Any

import numpy as np

from llmpas.examples.tamp2d_pds.pds2d_geometry import (
    GRIPPER_HALF,
    GRIPPER_HEIGHT,
    GRIPPER_WIDTH,
    Conf,
    Grasp,
    Pose,
    Traj,
    grasp_conf,
    overlaps,
    sample_path,
    swept_hits,
)
from llmpas.examples.tamp2d_pds.pds2d_world import Scene
from llmpas.language.bindings import Implementation, cost, function, sampler, test

STREAM_NAMES = (
    "sample-pose",
    "sample-grasp",
    "inverse-kinematics",
    "plan-motion",
    "test-cfree",
    "test-contain",
)
DEFERRABLE = ("inverse-kinematics", "plan-motion")
MAX_REJECTIONS = 200  # a sampler gives up after this many rejected samples in a row
MOVE_COST = 1.0  # fixed part of every move's cost


def sample_pose(
    world: Scene, rng: np.random.Generator, block: str, region: str
) -> Iterator[tuple[Pose]]:
    """Uniform poses of ``block`` on the ground inside ``region``, clear of the fixed obstacles."""
    b, r = world.block(block), world.region(region)
    lo, hi = r.lo + b.width / 2, r.hi - b.width / 2
    if hi < lo:
        return
    misses = 0
    while misses < MAX_REJECTIONS:
        p = b.resting(float(rng.uniform(lo, hi)))
        if any(overlaps(b.rect(p), o) for o in world.obstacles):
            misses += 1
            continue
        misses = 0
        yield (p,)


def sample_grasp(world: Scene, rng: np.random.Generator, block: str) -> Iterator[tuple[Grasp]]:
    """Suction on the middle of the top face first, then anywhere the gripper fits on it."""
    b = world.block(block)
    dy = b.height / 2 + GRIPPER_HEIGHT / 2
    room = max(0.0, b.width / 2 - GRIPPER_WIDTH / 2 - 0.05)
    yield (Grasp(0.0, dy),)
    while room > 0:
        yield (Grasp(round(float(rng.uniform(-room, room)), 6), dy),)


def inverse_kinematics(world: Scene, block: str, pose: Pose, grasp: Grasp) -> tuple[Conf] | None:
    """The gripper conf holding ``block`` at ``pose`` with ``grasp``, if the gripper there and
    the straight approach from travel height are clear of the fixed obstacles."""
    q = grasp_conf(pose, grasp)
    if not _in_workspace(world, q):
        return None
    above = Conf(q.x, world.carry)
    if _hits_obstacles(world, (above, q)):
        return None
    return (q,)


def plan_motion(world: Scene, q1: Conf, q2: Conf) -> tuple[Traj] | None:
    """Up to travel height, across, down; None unless every point of it (with a block hanging
    below the gripper while at travel height) is clear of the fixed obstacles."""
    if not (_in_workspace(world, q1) and _in_workspace(world, q2)):
        return None
    pts = [q1, Conf(q1.x, world.carry), Conf(q2.x, world.carry), q2]
    path = tuple(p for k, p in enumerate(pts) if k == 0 or p != pts[k - 1])
    if _hits_obstacles(world, path) or _hangs_into_obstacles(world, q1, q2):
        return None
    return (Traj(path),)


def _in_workspace(world: Scene, q: Conf) -> bool:
    g = world.ground
    return g.lo <= q.x <= g.hi and GRIPPER_HEIGHT / 2 <= q.y <= world.carry + 1e-9


def _hits_obstacles(world: Scene, path: tuple[Conf, ...]) -> bool:
    if not world.obstacles:
        return False
    hits = swept_hits(sample_path(path), GRIPPER_HALF, list(world.obstacles))
    return bool(hits.any())


def _hangs_into_obstacles(world: Scene, q1: Conf, q2: Conf) -> bool:
    """The traverse at travel height with the tallest block hanging below the gripper."""
    if not world.obstacles:
        return False
    drop = GRIPPER_HEIGHT / 2 + world.tallest / 2
    line = (Conf(q1.x, world.carry - drop), Conf(q2.x, world.carry - drop))
    half = (max(b.width for b in world.blocks) / 2, world.tallest / 2)
    return bool(swept_hits(sample_path(line), half, list(world.obstacles)).any())


def test_cfree(world: Scene, block1: str, pose1: Pose, block2: str, pose2: Pose) -> bool:
    """The two blocks' rectangles do not overlap (a block never collides with itself)."""
    if block1 == block2:
        return True
    return not overlaps(world.block(block1).rect(pose1), world.block(block2).rect(pose2))


def test_contain(world: Scene, block: str, pose: Pose, region: str) -> bool:
    return world.region(region).contains(world.block(block), pose)


def distance(world: Scene, q1: Conf, q2: Conf) -> float:
    """The cost of a move: ``MOVE_COST`` plus the length of the path :func:`plan_motion` makes."""
    up = abs(world.carry - q1.y) + abs(world.carry - q2.y)
    return MOVE_COST + up + abs(q2.x - q1.x)


def implementations(
    world: Scene, rng: np.random.Generator, deferred: Collection[str] = DEFERRABLE
) -> dict[str, Implementation]:
    """Every stream and function of ``stream.pddl`` bound to ``world``; ``deferred`` streams are
    marked deferred (the planner leaves them to execution when its ``defer`` is on)."""
    if not set(deferred) <= set(DEFERRABLE):
        wrong = sorted(set(deferred) - set(DEFERRABLE))[0]
        raise ValueError(f"unknown stream {wrong!r} to defer; deferrable: {', '.join(DEFERRABLE)}")
    geometry: dict[str, tuple[Callable[..., Any], float]] = {
        "inverse-kinematics": (inverse_kinematics, 0.5),
        "plan-motion": (plan_motion, 1.0),
    }
    return {
        "sample-pose": sampler(partial(sample_pose, world, rng)),
        "sample-grasp": sampler(partial(sample_grasp, world, rng), overhead=0.5),
        **{
            name: function(partial(fn, world), overhead=overhead, deferred=name in deferred)
            for name, (fn, overhead) in geometry.items()
        },
        "test-cfree": test(partial(test_cfree, world), overhead=0.1),
        "test-contain": test(partial(test_contain, world), overhead=0.1),
        "dist": cost(partial(distance, world)),
    }


__all__ = [
    "DEFERRABLE",
    "STREAM_NAMES",
    "distance",
    "implementations",
    "inverse_kinematics",
    "plan_motion",
    "sample_grasp",
    "sample_pose",
    "test_cfree",
    "test_contain",
]
