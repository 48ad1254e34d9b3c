"""Typed planner results: a status enum, the plan, and where the time went."""

from __future__ import annotations

import enum
import itertools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from llmpas.language.logic import Atom


class PlanStatus(enum.Enum):
    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"
    TIMEOUT = "timeout"  # a time limit (a safety net) fired: depends on the machine's load
    LIMIT = "limit"  # a counted limit of the config was reached: not a proof of unsolvability
    CRASHED = "crashed"  # the classical planner (translator or search) died: not a timeout
    ERROR = "error"


@dataclass(frozen=True)
class StreamInstance:
    """One call site of a stream: its inputs and the names of its outputs."""

    stream: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    def __str__(self) -> str:
        outs = f" -> ({' '.join(self.outputs)})" if self.outputs else ""
        return f"{self.stream}({' '.join(self.inputs)}){outs}"


@dataclass(frozen=True)
class PlanStep:
    """A ground action, with the deferred stream instances the executor must satisfy for it."""

    action: str
    args: tuple[str, ...]
    deferred: tuple[StreamInstance, ...] = ()

    def __str__(self) -> str:
        return "(" + " ".join((self.action, *self.args)) + ")"


@dataclass(frozen=True, eq=False)
class Plan:
    steps: tuple[PlanStep, ...]
    cost: float
    # every object name the plan mentions -> its Python value (placeholders of deferred streams
    # map to None until the executor evaluates them)
    objects: Mapping[str, Any] = field(default_factory=dict)
    # facts produced by evaluated streams plus those assumed for deferred ones
    certified: frozenset[Atom] = frozenset()
    # deferred stream instances in the order they are needed, with what they certify
    deferred: tuple[StreamInstance, ...] = ()
    deferred_facts: Mapping[StreamInstance, tuple[Atom, ...]] = field(default_factory=dict)
    # facts of streams with ``:fluents`` the plan relies on (also in ``certified``), each with
    # the contexts (fluent facts) it was certified in: it holds only in states with those facts
    fluent_facts: Mapping[Atom, frozenset[frozenset[Atom]]] = field(default_factory=dict)
    # facts streams reported beyond their certified ones (PDDLStream's WildOutput; also in
    # ``certified``): true on the stream's word, as certified facts are
    reported: frozenset[Atom] = frozenset()

    def __post_init__(self) -> None:
        object.__setattr__(self, "objects", MappingProxyType(dict(self.objects)))
        object.__setattr__(self, "deferred_facts", MappingProxyType(dict(self.deferred_facts)))
        object.__setattr__(self, "fluent_facts", MappingProxyType(dict(self.fluent_facts)))
        if self.cost < 0:
            raise ValueError(f"plan cost must be >= 0, got {self.cost}")

    def __len__(self) -> int:
        return len(self.steps)

    @property
    def placeholders(self) -> frozenset[str]:
        return frozenset(o for inst in self.deferred for o in inst.outputs)


@dataclass(frozen=True)
class PlanStats:
    algorithm: str = ""
    quality: str = ""
    iterations: int = 0
    stream_calls: Mapping[str, int] = field(default_factory=dict)
    stream_time: float = 0.0
    translate_time: float = 0.0
    search_time: float = 0.0
    total_time: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "stream_calls", MappingProxyType(dict(self.stream_calls)))


@dataclass(frozen=True, eq=False)
class Improvement:
    """A plan found while planning, cheaper than every one before it: when (wall and CPU
    seconds since the call started; CPU counts the Fast Downward children; and in counts:
    the iteration and the stream calls so far) and what it costs."""

    time: float
    cpu: float
    cost: float
    plan: Plan
    iteration: int = 0  # the planning-loop iteration in which it became the incumbent
    stream_calls: int = 0  # stream calls made until then

    def to_json(self) -> dict[str, float]:
        return {
            "time": self.time,
            "cpu": self.cpu,
            "cost": self.cost,
            "length": len(self.plan),
            "iteration": self.iteration,
            "stream_calls": self.stream_calls,
        }


@dataclass(frozen=True)
class PlanResult:
    """``improvements``: every plan that became the incumbent, in order, each cheaper than the
    one before (one entry, the plan itself, unless the quality is ``anytime``)."""

    status: PlanStatus
    plan: Plan | None
    stats: PlanStats
    message: str = ""
    improvements: tuple[Improvement, ...] = ()

    def __post_init__(self) -> None:
        if (self.plan is not None) != (self.status is PlanStatus.SOLVED):
            raise ValueError("a plan is present exactly when the status is SOLVED")
        costs = [i.cost for i in self.improvements]
        if any(b >= a for a, b in itertools.pairwise(costs)):
            raise ValueError(f"improvements must get cheaper, got costs {costs}")
        if self.improvements and self.improvements[-1].plan is not self.plan:
            raise ValueError("the last improvement must be the plan returned")

    @property
    def solved(self) -> bool:
        return self.status is PlanStatus.SOLVED

    def to_json(self) -> dict[str, Any]:
        s = self.stats
        out: dict[str, Any] = {
            "status": self.status.value,
            "message": self.message,
            "stats": {
                "algorithm": s.algorithm,
                "quality": s.quality,
                "iterations": s.iterations,
                "stream_calls": dict(s.stream_calls),
                "stream_time": s.stream_time,
                "translate_time": s.translate_time,
                "search_time": s.search_time,
                "total_time": s.total_time,
            },
        }
        if self.plan is not None:
            out["plan"] = {
                "cost": self.plan.cost,
                "steps": [
                    {
                        "action": st.action,
                        "args": list(st.args),
                        "deferred": [str(d) for d in st.deferred],
                    }
                    for st in self.plan.steps
                ],
            }
            out["improvements"] = [i.to_json() for i in self.improvements]
        return out

    def dumps(self) -> str:
        return json.dumps(self.to_json(), indent=2)


Algorithm = str  # a name in llmpas.planning.planner_registry.ALGORITHMS
