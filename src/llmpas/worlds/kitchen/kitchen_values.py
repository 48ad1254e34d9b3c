"""Values every kitchen world shares: where the mobile base stands and how the gripper holds."""

from __future__ import annotations

import math
from dataclasses import dataclass


class Planar:
    """A value with a position on the floor plane: ``x``, ``y`` (metres)."""

    x: float
    y: float

    def distance(self, other: Planar) -> float:
        """The distance on the floor plane (heights and headings aside)."""
        return math.hypot(self.x - other.x, self.y - other.y)


def require_finite(what: str, value: object, *numbers: float) -> None:
    """A ValueError naming ``what`` and the value unless all ``numbers`` are finite."""
    if not all(math.isfinite(v) for v in numbers):
        raise ValueError(f"non-finite {what} {value}")


@dataclass(frozen=True)
class BaseConf(Planar):
    """Where the mobile base stands: x, y (metres) and heading (radians)."""

    x: float
    y: float
    theta: float

    def __post_init__(self) -> None:
        require_finite("base configuration", self, self.x, self.y, self.theta)

    @property
    def pose(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.theta)

    def __str__(self) -> str:
        return f"base({self.x:.2f},{self.y:.2f},{math.degrees(self.theta):.0f}deg)"


@dataclass(frozen=True)
class Grasp:
    """How the gripper holds an object: from the top or from the front."""

    kind: str  # "top" | "forward"

    def __post_init__(self) -> None:
        if self.kind not in ("top", "forward"):
            raise ValueError(f"grasp kind must be 'top' or 'forward', got {self.kind!r}")

    def __str__(self) -> str:
        return f"{self.kind}-grasp"


PHASES = ("pre", "at")
"""Where an arm goal brings the gripper: ``pre`` (clear of the object) or ``at`` it."""


def check_phase(phase: str) -> None:
    if phase not in PHASES:
        raise ValueError(f"phase must be 'pre' or 'at', got {phase!r}")


__all__ = ["PHASES", "BaseConf", "Grasp", "Planar", "check_phase", "require_finite"]
