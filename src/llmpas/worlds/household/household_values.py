"""Values shared by the household world, its streams and its behaviour subtrees."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from llmpas.worlds.kitchen.kitchen_values import BaseConf, Grasp, Planar, check_phase


@dataclass(frozen=True)
class Placement(Planar):
    """Where an object rests: a region name and a position in it (x, y on the floor plane)."""

    region: str
    x: float
    y: float

    def __str__(self) -> str:
        return f"{self.region}@({self.x:.2f},{self.y:.2f})"


@dataclass(frozen=True)
class ArmTarget:
    """Where the arm should bring the gripper: above/at a point, for a grasp kind.

    ``phase``: ``pre`` (pre-approach: clear of the object), ``at`` (grasp/release position).
    """

    x: float
    y: float
    z: float
    grasp: Grasp
    phase: str = "at"

    def __post_init__(self) -> None:
        check_phase(self.phase)


@dataclass(frozen=True)
class Motion:
    """A base path: way points from one configuration to another."""

    waypoints: tuple[BaseConf, ...]

    @property
    def length(self) -> float:
        w = self.waypoints
        return sum(a.distance(b) for a, b in itertools.pairwise(w))


__all__ = ["ArmTarget", "BaseConf", "Grasp", "Motion", "Placement"]
