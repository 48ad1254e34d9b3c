"""What the executor needs from a world: a :class:`Robot` with skills and a :class:`Perception`.

Worlds (the household world, the PyBullet world, test doubles) implement these Protocols. The
executor never reads a world's true state: everything it believes comes through perception.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable


class SkillStatus(enum.Enum):
    SUCCESS = "success"
    FAILURE = "failure"


@dataclass(frozen=True)
class SkillResult:
    """The outcome of one robot skill, with what the robot can tell about it."""

    status: SkillStatus
    message: str = ""
    data: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "data", MappingProxyType(dict(self.data)))

    @property
    def ok(self) -> bool:
        return self.status is SkillStatus.SUCCESS

    @classmethod
    def success(cls, message: str = "", **data: Any) -> SkillResult:
        return cls(SkillStatus.SUCCESS, message, data)

    @classmethod
    def failure(cls, message: str, **data: Any) -> SkillResult:
        return cls(SkillStatus.FAILURE, message, data)


@dataclass(frozen=True)
class Detection:
    """An object seen by the robot: where (a region name) and an estimated pose (world values)."""

    obj: str
    region: str
    pose: Any
    confidence: float = 1.0
    properties: frozenset[str] = frozenset()  # visible states such as "dirty", "cooked"

    def __post_init__(self) -> None:
        if not 0.0 <= self.confidence <= 1.0:
            raise ValueError(f"confidence must be in [0, 1], got {self.confidence}")


@dataclass(frozen=True)
class Observation:
    """One look: the regions that were in view and what was detected in them."""

    viewed: tuple[str, ...]
    detections: tuple[Detection, ...] = ()

    def find(self, obj: str) -> Detection | None:
        hits = [d for d in self.detections if d.obj == obj]
        return max(hits, key=lambda d: d.confidence) if hits else None

    def in_region(self, region: str) -> tuple[Detection, ...]:
        return tuple(d for d in self.detections if d.region == region)


@runtime_checkable
class Robot(Protocol):
    """Skills of a mobile manipulator. Parameters are world values (poses, configurations)."""

    def move_base(self, conf: Any) -> SkillResult: ...

    def move_arm(self, target: Any) -> SkillResult: ...

    def grasp(self, obj: str, grasp: Any) -> SkillResult: ...

    def release(self, obj: str, pose: Any) -> SkillResult: ...

    def open(self, container: str) -> SkillResult: ...

    def close(self, container: str) -> SkillResult: ...

    def process(self, obj: str, appliance: str, how: str) -> SkillResult:
        """clean / heat / cook / cool ``obj`` with ``appliance``."""
        ...

    def base_conf(self) -> Any: ...

    def holding(self) -> str | None: ...


@runtime_checkable
class Perception(Protocol):
    """What the robot sees. ``look(target)`` points the sensors at a region (or the current
    view when ``target`` is None) and reports, with noise, what is visible there."""

    def look(self, target: str | None = None) -> Observation: ...
