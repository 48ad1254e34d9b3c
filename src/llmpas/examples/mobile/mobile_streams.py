"""Python implementations of the kitchen streams: plain functions of the kitchen and an rng."""

from __future__ import annotations

from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from llmpas.examples.mobile.mobile_geometry import BaseWorld, FloatArray
from llmpas.examples.mobile.mobile_motion import RRTParams, plan_base_path
from llmpas.examples.mobile.mobile_world import (
    BASE_HALF_LENGTH,
    ArmTraj,
    BaseConf,
    BaseTraj,
    Grasp,
    Kitchen,
    ObjPose,
    footprints_apart,
    placement_area,
)
from llmpas.examples.mobile.robot import approach_path, facing, grasp_point
from llmpas.language.bindings import Implementation, cost, function, sampler, test

STREAM_NAMES = (
    "sample-pose",
    "sample-grasp",
    "inverse-kinematics",
    "plan-base-motion",
    "test-cfree-pose-pose",
)
DEFAULT_DEFERRED = ("plan-base-motion", "inverse-kinematics")
GRASPS = (Grasp("top"), Grasp("side"))


@dataclass(frozen=True)
class KinParams:
    attempts: int = 2  # collision-free base samples tried per call
    candidates: int = 32  # raw samples drawn to find one collision-free base position
    near: float = BASE_HALF_LENGTH + 0.05  # base centre distance to the object, from ...
    far: float = 1.4  # ... to (beyond the arm's reach: some samples fail)


@dataclass(frozen=True)
class StreamParams:
    kin: KinParams = field(default_factory=KinParams)
    rrt: RRTParams = field(default_factory=RRTParams)


def sample_pose(
    kitchen: Kitchen, rng: np.random.Generator, obj: str, region: str
) -> Iterator[tuple[ObjPose]]:
    """Endless uniform placements of ``obj`` on ``region`` with a random yaw."""
    s = kitchen.surface(region)
    area = placement_area(s, kitchen.obj(obj))
    while True:
        x, y = area.sample(rng)
        yield (ObjPose(x, y, s.z, float(rng.uniform(-np.pi, np.pi))),)


def sample_grasp(kitchen: Kitchen, obj: str) -> Iterator[tuple[Grasp]]:
    """The top grasp, then the forward (side) grasp."""
    kitchen.obj(obj)  # unknown objects fail loudly
    for g in GRASPS:
        yield (g,)


def inverse_kinematics(
    kitchen: Kitchen,
    rng: np.random.Generator,
    params: KinParams,
    arm: str,
    obj: str,
    pose: ObjPose,
    grasp: Grasp,
) -> tuple[BaseConf, ArmTraj] | None:
    """A collision-free base conf near ``pose`` facing the object and an arm trajectory from
    tucked to ``grasp``; a few random base samples are tried, then None (like sampled IK)."""
    spec = kitchen.obj(obj)
    point = grasp_point(spec, pose, grasp)
    world = kitchen.base_world()
    for _ in range(params.attempts):
        q = _free_base_near(pose, world, rng, params)
        if q is None:
            continue
        base = BaseConf(float(q[0]), float(q[1]), facing(q[:2], point))
        path = approach_path(base, spec, pose, grasp, kitchen.obstacles)
        if path is not None:
            joints = tuple((float(q[0]), float(q[1]), float(q[2])) for q in path)
            return base, ArmTraj(arm, base, joints)
    return None


def _free_base_near(
    pose: ObjPose, world: BaseWorld, rng: np.random.Generator, params: KinParams
) -> FloatArray | None:
    """A collision-free base configuration facing ``pose`` from the annulus around it
    (rejection sampling)."""
    angle = rng.uniform(-np.pi, np.pi, params.candidates)
    dist = rng.uniform(params.near, params.far, params.candidates)
    q = np.stack([pose.x - dist * np.cos(angle), pose.y - dist * np.sin(angle), angle], axis=1)
    free = np.flatnonzero(world.free(q))
    return q[free[0]] if free.size else None


def plan_base_motion(
    kitchen: Kitchen, rng: np.random.Generator, params: RRTParams, q1: BaseConf, q2: BaseConf
) -> tuple[BaseTraj] | None:
    """A collision-free drive (RRT-Connect + shortcuts); None if none was found."""
    traj = plan_base_path(q1, q2, kitchen.base_world(), rng, params)
    return None if traj is None else (traj,)


def test_cfree_pose_pose(kitchen: Kitchen, o1: str, p1: ObjPose, o2: str, p2: ObjPose) -> bool:
    """The two objects' footprints do not overlap (an object never collides with itself)."""
    if o1 == o2:
        return True
    return footprints_apart(kitchen.obj(o1), p1, kitchen.obj(o2), p2)


def distance(q1: BaseConf, q2: BaseConf) -> float:
    """Cost of a drive: 1 plus the straight-line distance."""
    return 1.0 + float(np.hypot(q2.x - q1.x, q2.y - q1.y))


def implementations(
    kitchen: Kitchen,
    rng: np.random.Generator,
    deferred: Collection[str] = DEFAULT_DEFERRED,
    params: StreamParams | None = None,
) -> dict[str, Implementation]:
    """Every stream and function of ``stream.pddl`` bound to ``kitchen``."""
    unknown = sorted(set(deferred) - set(STREAM_NAMES))
    if unknown:
        raise ValueError(f"unknown stream {unknown[0]!r}; streams are {', '.join(STREAM_NAMES)}")
    p = params or StreamParams()
    return {
        "sample-pose": sampler(partial(sample_pose, kitchen, rng), overhead=1.0),
        "sample-grasp": sampler(partial(sample_grasp, kitchen), overhead=0.1, max_outputs=2),
        "inverse-kinematics": function(
            partial(inverse_kinematics, kitchen, rng, p.kin),
            overhead=5.0,
            p_success=0.9,
            deferred="inverse-kinematics" in deferred,
        ),
        "plan-base-motion": function(
            partial(plan_base_motion, kitchen, rng, p.rrt),
            overhead=20.0,
            p_success=0.95,
            deferred="plan-base-motion" in deferred,
        ),
        "test-cfree-pose-pose": test(partial(test_cfree_pose_pose, kitchen), overhead=0.1),
        "distance": cost(distance),
    }
