"""Stream implementations of the household domain (``stream.pddl``), with real geometry.

``inverse-kinematics``, ``sample-view`` and ``plan-base-motion`` are deferred by default: the
planner assumes them and the executor evaluates them with what the robot perceives.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterator, Mapping
from typing import Any

import numpy as np

from llmpas.language.bindings import Implementation, cost, function, sampler, test
from llmpas.worlds.household.household_geometry import base_poses_near, drive
from llmpas.worlds.household.household_values import BaseConf, Grasp, Motion, Placement
from llmpas.worlds.household.layout import Layout, ObjectSpec

DEFAULT_DEFERRED = ("inverse-kinematics", "sample-view", "plan-base-motion")

Locator = Callable[[str], Placement | None]  # where a receptacle object is believed to be


def pose_sampler(
    layout: Layout, objects: Mapping[str, ObjectSpec], locate: Locator, rng: np.random.Generator
) -> Callable[[str, str], Iterator[tuple[Placement]]]:
    def sample_pose(o: str, r: str) -> Iterator[tuple[Placement]]:
        if r in objects:  # a receptacle object (a bowl): its middle
            at = locate(r)
            if at is not None:
                yield (Placement(r, at.x, at.y),)
            return
        x0, y0, x1, y1 = layout.region(r).rect
        m = objects[o].radius + 0.02
        if x1 - x0 <= 2 * m or y1 - y0 <= 2 * m:
            return
        doors = [d.name for d in layout.regions.values() if d.front is not None]
        floor = layout.on_floor(r)
        while True:
            x, y = rng.uniform(x0 + m, x1 - m), rng.uniform(y0 + m, y1 - m)
            x, y = round(float(x), 3), round(float(y), 3)
            if floor and any(layout.blocked_by(d, x, y, objects[o].radius) for d in doors):
                continue  # never put anything down in front of a door
            yield (Placement(r, x, y),)

    return sample_pose


def grasps(objects: Mapping[str, ObjectSpec]) -> Callable[[str], Iterator[tuple[Grasp]]]:
    def sample_grasp(o: str) -> Iterator[tuple[Grasp]]:
        yield (Grasp("top"),)
        if not objects[o].cover:
            yield (Grasp("forward"),)

    return sample_grasp


def kin(layout: Layout, rng: np.random.Generator, samples: int = 6) -> Callable[..., Iterator[Any]]:
    """Base poses from which the arm reaches the placement."""

    def inverse_kinematics(o: str, p: Placement, g: Grasp) -> Iterator[tuple[BaseConf]]:
        reach = layout.reach * (0.9 if g.kind == "forward" else 1.0)
        gen = base_poses_near(layout, p.x, p.y, rng, reach)
        for _ in range(samples):
            yield (next(gen),)

    return inverse_kinematics


def view(layout: Layout, rng: np.random.Generator, samples: int = 6) -> Callable[..., Any]:
    def sample_view(r: str) -> Iterator[tuple[BaseConf]]:
        region = layout.regions.get(r)
        if region is None:
            return
        x, y = region.center()
        gen = base_poses_near(layout, x, y, rng)
        for _ in range(samples):
            yield (next(gen),)

    return sample_view


def make_streams(
    layout: Layout,
    objects: Mapping[str, ObjectSpec],
    locate: Locator,
    rng: np.random.Generator,
    deferred: Collection[str] = DEFAULT_DEFERRED,
) -> dict[str, Implementation]:
    """Implementations bound by stream name; ``deferred`` streams are left to execution."""

    def motion(q1: BaseConf, q2: BaseConf) -> tuple[Motion] | None:
        m = drive(layout, q1, q2)
        return None if m is None else (m,)

    def cfree(o: str, p: Placement, o2: str, p2: Placement) -> bool:
        if o == o2 or p.region != p2.region:
            return True
        return p.distance(p2) >= objects[o].radius + objects[o2].radius

    def distance(q1: BaseConf, q2: BaseConf) -> float:
        return 1.0 + math.hypot(q1.x - q2.x, q1.y - q2.y)

    return {
        "sample-pose": sampler(pose_sampler(layout, objects, locate, rng), max_outputs=8),
        # one grasp is enough to plan with: the executor explores the others (CSubBT)
        "sample-grasp": sampler(grasps(objects), max_outputs=1),
        "inverse-kinematics": sampler(kin(layout, rng), deferred="inverse-kinematics" in deferred),
        "sample-view": sampler(view(layout, rng), deferred="sample-view" in deferred),
        "plan-base-motion": function(motion, deferred="plan-base-motion" in deferred),
        "test-cfree": test(cfree),
        "distance": cost(distance),
    }
