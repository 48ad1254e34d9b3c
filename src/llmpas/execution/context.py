"""The execution context: the world interfaces, the believed state, the record, the rng.

A :class:`Context` is passed explicitly to every CSubBT node (through its blackboard); nothing is
module-global. The :class:`Belief` is the only mutable model of the world the executor has; it is
changed by perception and by the effects of completed actions, never by reading a world's truth.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from llmpas.execution.robot_protocols import Observation, Perception, Robot
from llmpas.language.logic import Atom


class Belief:
    """Believed facts and the values of the objects they mention."""

    def __init__(self, facts: Iterable[Atom], values: Mapping[str, Any]) -> None:
        self.facts: set[Atom] = set(facts)
        self.values: dict[str, Any] = dict(values)
        self.observations: list[Observation] = []

    def name(self, prefix: str, value: Any) -> str:
        """A fresh object name for ``value`` (``prefix``, ``prefix_1``, ...), recorded."""
        name, k = prefix, 0
        while name in self.values:
            k += 1
            name = f"{prefix}_{k}"
        self.values[name] = value
        return name

    def snapshot(self) -> frozenset[Atom]:
        return frozenset(self.facts)

    def replace(self, remove: Iterable[Atom], add: Iterable[Atom]) -> None:
        self.facts -= set(remove)
        self.facts |= set(add)

    def matching(self, predicate: str, *args: str | None) -> list[Atom]:
        """Facts of ``predicate`` whose arguments equal ``args`` where given (None: any)."""
        return sorted(
            a
            for a in self.facts
            if a.predicate == predicate
            and all(x is None or x == y for x, y in zip(args, a.args, strict=False))
        )


@dataclass(frozen=True)
class Event:
    """One line of an episode's timeline."""

    t: float
    node: str
    status: str
    message: str = ""
    values: Mapping[str, str] = field(default_factory=dict)


class Recorder:
    """Collects the timeline of an execution."""

    def __init__(self) -> None:
        self.start = time.perf_counter()
        self.events: list[Event] = []

    def event(
        self, node: str, status: str, message: str = "", values: Mapping[str, Any] | None = None
    ) -> None:
        shown = {k: _short(v) for k, v in (values or {}).items()}
        self.events.append(Event(time.perf_counter() - self.start, node, status, message, shown))


def _short(v: Any, limit: int = 60) -> str:
    if isinstance(v, np.ndarray):
        text = np.array2string(v, precision=3, separator=",")
    elif isinstance(v, float):
        text = f"{v:.3f}"
    else:
        text = str(v)
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass
class Context:
    robot: Robot
    perception: Perception
    belief: Belief
    rng: np.random.Generator
    recorder: Recorder = field(default_factory=Recorder)
    # the constraint space of the subtree that is running (set by its Explore decorator)
    space: Any = None
    polls: int = 0  # polls of skills that were still running (the executor waits a period)

    def perceive(self, key: str, value: Any) -> None:
        """Record a perception (e.g. a detected pose) for the running subtree's samplers."""
        if self.space is not None:
            self.space.perceive(key, value)
