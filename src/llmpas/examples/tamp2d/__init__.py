"""A 2-D continuous pick-and-place domain: blocks of different widths on a long table."""

from llmpas.examples.tamp2d.tamp2d_problem import PACKAGE, goal_facts, init_facts, make_problem
from llmpas.examples.tamp2d.tamp2d_streams import (
    STREAM_NAMES,
    distance,
    implementations,
    inverse_kinematics,
    plan_motion,
    sample_pose,
    test_cfree,
)
from llmpas.examples.tamp2d.tamp2d_world import (
    BlockSpec,
    Conf,
    Interval,
    Pose,
    Scene,
    Traj,
    make_world,
    overlap,
)

__all__ = [
    "PACKAGE",
    "STREAM_NAMES",
    "BlockSpec",
    "Conf",
    "Interval",
    "Pose",
    "Scene",
    "Traj",
    "distance",
    "goal_facts",
    "implementations",
    "init_facts",
    "inverse_kinematics",
    "make_problem",
    "make_world",
    "overlap",
    "plan_motion",
    "sample_pose",
    "test_cfree",
]
