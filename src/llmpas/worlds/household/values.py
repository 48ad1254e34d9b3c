"""Values shared by the household world, its streams and its behaviour subtrees."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class BaseConf:
    """Where the mobile base stands: x, y (metres) and heading (radians)."""

    x: float
    y: float
    theta: float

    def distance(self, other: BaseConf) -> float:
        return math.hypot(self.x - other.x, self.y - other.y)

    def __str__(self) -> str:
        return f"base({self.x:.2f},{self.y:.2f},{math.degrees(self.theta):.0f}deg)"


@dataclass(frozen=True)
class Placement:
    """Where an object rests: a region name and a position in it (x, y on the floor plane)."""

    region: str
    x: float
    y: float

    def distance(self, other: Placement) -> float:
        return math.hypot(self.x - other.x, self.y - other.y)

    def __str__(self) -> str:
        return f"{self.region}@({self.x:.2f},{self.y:.2f})"


@dataclass(frozen=True)
class Grasp:
    """How the gripper holds an object: from the top or from the front."""

    kind: str  # "top" | "forward"

    def __post_init__(self) -> None:
        if self.kind not in ("top", "forward"):
            raise ValueError(f"grasp kind must be 'top' or 'forward', got {self.kind!r}")

    def __str__(self) -> str:
        return f"{self.kind}-grasp"


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
        if self.phase not in ("pre", "at"):
            raise ValueError(f"phase must be 'pre' or 'at', got {self.phase!r}")


@dataclass(frozen=True)
class Motion:
    """A base path: way points from one configuration to another."""

    waypoints: tuple[BaseConf, ...]

    @property
    def length(self) -> float:
        w = self.waypoints
        return sum(a.distance(b) for a, b in itertools.pairwise(w))
