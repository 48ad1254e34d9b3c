"""Python implementations of the tamp2d streams: plain functions of the world (and an rng)."""

from __future__ import annotations

from collections.abc import Collection, Iterator
from functools import partial

import numpy as np

from llmpas.examples.tamp2d.tamp2d_world import GRIP_OFFSET, Conf, Pose, Scene, Traj, overlap
from llmpas.language.bindings import Implementation, cost, function, sampler, test

STREAM_NAMES = ("sample-pose", "inverse-kinematics", "plan-motion", "test-cfree")


def sample_pose(
    world: Scene, rng: np.random.Generator, block: str, region: str
) -> Iterator[tuple[Pose]]:
    """Endless uniform samples of poses that put ``block`` entirely inside ``region``."""
    b, r = world.block(block), world.region(region)
    lo, hi = r.lo + b.width / 2, r.hi - b.width / 2
    if hi < lo:
        return
    while True:
        yield (Pose(float(rng.uniform(lo, hi))),)


def inverse_kinematics(world: Scene, block: str, pose: Pose) -> tuple[Conf] | None:
    """The gripper right above ``block`` at ``pose``; None when the pose is off the table."""
    b = world.block(block)
    if not world.table.contains(b, pose):
        return None
    return (Conf(pose.x, b.height + GRIP_OFFSET),)


def plan_motion(world: Scene, q1: Conf, q2: Conf) -> tuple[Traj] | None:
    """Up to travel height, across, down: clear of every block, held or standing."""
    if not (_in_workspace(world, q1) and _in_workspace(world, q2)):
        return None
    top = world.travel_height
    points = [q1, Conf(q1.x, top), Conf(q2.x, top), q2]
    path = [p for k, p in enumerate(points) if k == 0 or p != points[k - 1]]
    return (Traj(tuple(path)),)


def _in_workspace(world: Scene, q: Conf) -> bool:
    t = world.table
    return t.lo <= q.x <= t.hi and 0.0 < q.y <= world.travel_height


def test_cfree(world: Scene, block1: str, pose1: Pose, block2: str, pose2: Pose) -> bool:
    """The footprints of the two blocks do not overlap (a block never collides with itself)."""
    if block1 == block2:
        return True
    return not overlap(world.block(block1), pose1, world.block(block2), pose2)


def distance(world: Scene, q1: Conf, q2: Conf) -> float:
    """The length of the trajectory :func:`plan_motion` makes from ``q1`` to ``q2``."""
    top = world.travel_height
    return abs(top - q1.y) + abs(q2.x - q1.x) + abs(top - q2.y)


def implementations(
    world: Scene, rng: np.random.Generator, deferred: Collection[str] = ()
) -> dict[str, Implementation]:
    """Every stream and function of ``stream.pddl`` bound to ``world``; ``deferred`` streams are
    left for the executor."""
    unknown = sorted(set(deferred) - set(STREAM_NAMES))
    if unknown:
        raise ValueError(f"unknown stream {unknown[0]!r}; streams are {', '.join(STREAM_NAMES)}")
    return {
        "sample-pose": sampler(partial(sample_pose, world, rng), overhead=1.0),
        "inverse-kinematics": function(
            partial(inverse_kinematics, world),
            overhead=0.5,
            deferred="inverse-kinematics" in deferred,
        ),
        "plan-motion": function(
            partial(plan_motion, world), overhead=1.0, deferred="plan-motion" in deferred
        ),
        "test-cfree": test(partial(test_cfree, world), overhead=0.1),
        "dist": cost(partial(distance, world)),
    }
