"""What the executor needs from a world: a :class:`Robot` with skills and a :class:`Perception`.

Worlds (the household world, the PyBullet world, test doubles) implement these Protocols. The
executor never reads a world's true state: everything it believes comes through perception.

A skill returns a :class:`SkillHandle` (a goal the robot is carrying out: ``poll()`` it,
``cancel()`` it) or a plain :class:`SkillResult` (a skill that ran to its end: an in-process
world's), which the executor reads as a :class:`Completed` handle.
"""

from __future__ import annotations

import enum
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable


class SkillStatus(enum.Enum):
    SUCCESS = "success"
    FAILURE = "failure"
    RUNNING = "running"  # only from a handle's poll(): the skill has not ended yet


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

    @property
    def running(self) -> bool:
        return self.status is SkillStatus.RUNNING

    @classmethod
    def success(cls, message: str = "", **data: Any) -> SkillResult:
        return cls(SkillStatus.SUCCESS, message, data)

    @classmethod
    def failure(cls, message: str, **data: Any) -> SkillResult:
        return cls(SkillStatus.FAILURE, message, data)

    @classmethod
    def still_running(cls, message: str = "", **data: Any) -> SkillResult:
        return cls(SkillStatus.RUNNING, message, data)


@runtime_checkable
class SkillHandle(Protocol):
    """A skill under way (a robot's action goal). ``poll()`` never blocks: a RUNNING result
    until the skill ends, then its final result (the same at every later poll). ``cancel()``
    asks the robot to stop it (nothing once it has ended)."""

    def poll(self) -> SkillResult: ...

    def cancel(self) -> None: ...


@dataclass(frozen=True)
class Completed:
    """The handle of a skill that has already ended (an in-process world's skill)."""

    result: SkillResult

    def __post_init__(self) -> None:
        if self.result.running:
            raise ValueError("a completed skill's result cannot be RUNNING")

    def poll(self) -> SkillResult:
        return self.result

    def cancel(self) -> None:
        """Nothing to stop: the skill has ended."""


Outcome = SkillResult | SkillHandle  # what a skill returns


def as_handle(outcome: Outcome) -> SkillHandle:
    """A skill's outcome as a handle: a plain result is a :class:`Completed` one."""
    if isinstance(outcome, SkillResult):
        return Completed(outcome)
    if not isinstance(outcome, SkillHandle):
        raise TypeError(f"a skill returned {type(outcome).__name__}, not a result or a handle")
    return outcome


def finish(outcome: Outcome, period: float = 0.002) -> SkillResult:
    """Wait for a skill's end (polling every ``period`` s): for the parts of a skill that
    chain several skills, and for perception. Ctrl-C cancels it, then goes on."""
    handle = as_handle(outcome)
    try:
        result = handle.poll()
        while result.running:
            time.sleep(period)
            result = handle.poll()
    except KeyboardInterrupt:
        handle.cancel()
        raise
    return result


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
    """Skills of a mobile manipulator. Parameters are world values (poses, configurations).
    Each skill returns a plain result (it has ended) or a handle to poll."""

    def move_base(self, conf: Any) -> Outcome: ...

    def move_arm(self, target: Any) -> Outcome: ...

    def grasp(self, obj: str, grasp: Any) -> Outcome: ...

    def release(self, obj: str, pose: Any) -> Outcome: ...

    def open(self, container: str) -> Outcome: ...

    def close(self, container: str) -> Outcome: ...

    def process(self, obj: str, appliance: str, how: str) -> Outcome:
        """clean / heat / cook / cool ``obj`` with ``appliance``."""
        ...

    def base_conf(self) -> Any: ...

    def holding(self) -> str | None: ...


@runtime_checkable
class Perception(Protocol):
    """What the robot sees. ``look(target)`` points the sensors at a region (or the current
    view when ``target`` is None) and reports, with noise, what is visible there."""

    def look(self, target: str | None = None) -> Observation: ...
