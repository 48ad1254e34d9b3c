"""Values of the PyBullet world shared by its streams, skills and perception."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from llmpas.worlds.kitchen.kitchen_values import (
    BaseConf,
    Grasp,
    Planar,
    check_phase,
    require_finite,
)


@dataclass(frozen=True)
class ObjectPose(Planar):
    """Where an object rests: the region it is in (a table or a bowl) and its centre (world)."""

    region: str
    x: float
    y: float
    z: float

    def __post_init__(self) -> None:
        require_finite("pose", self, self.x, self.y, self.z)

    def __str__(self) -> str:
        return f"{self.region}@({self.x:.2f},{self.y:.2f},{self.z:.2f})"


Vector = Sequence[float] | np.ndarray  # a point, direction or quaternion


@dataclass(frozen=True)
class BasePath:
    """A planned drive: dense way points (x, y, heading)."""

    waypoints: tuple[tuple[float, float, float], ...]

    def __post_init__(self) -> None:
        if len(self.waypoints) < 1:
            raise ValueError("a base path needs at least one way point")

    @property
    def length(self) -> float:
        w = self.waypoints
        return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(w))

    def __str__(self) -> str:
        return f"path({len(self.waypoints)} pts, {self.length:.2f} m)"


@dataclass(frozen=True)
class ArmGoal:
    """Where the arm should bring the gripper: before (``pre``) or at (``at``) the grasp of an
    object resting at ``pose``."""

    pose: ObjectPose
    grasp: Grasp
    phase: str = "at"
    obj: str = ""  # the object grasped or held (its size sets the grasp height)

    def __post_init__(self) -> None:
        check_phase(self.phase)


__all__ = ["ArmGoal", "BaseConf", "BasePath", "Grasp", "ObjectPose", "Vector"]
