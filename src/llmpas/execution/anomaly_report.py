"""Structured anomaly reports: what failed, what was explored, what the robot believes."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from llmpas.language.logic import Atom, Not

if TYPE_CHECKING:
    from llmpas.execution.context import Context
    from llmpas.execution.csubbt import Constraint, SubtreeSpec
    from llmpas.execution.space import ConstraintSpace


@dataclass(frozen=True)
class Failure:
    """A constraint (or skill) that failed once inside a subtree."""

    sub_action: str
    constraint: Constraint
    reason: str
    values: Mapping[str, Any]
    exhausted: bool = False


@dataclass(frozen=True)
class AnomalyReport:
    """Why a CSubBT gave up, as data (JSON-serialisable) and as a sentence for prompts."""

    action: str
    args: tuple[str, ...]
    steps: tuple[int, ...]
    subtree: str
    sub_action: str
    constraint: Atom | Not  # the unsatisfied literal
    constraint_name: str
    reason: str
    explored: Mapping[str, tuple[str, ...]]
    attempts: int
    failures: Mapping[str, int]  # constraint name -> how often it failed
    observations: tuple[str, ...]
    belief: tuple[Atom, ...]
    plan_atoms: tuple[Atom, ...] = field(default_factory=tuple)

    @classmethod
    def build(
        cls,
        spec: SubtreeSpec,
        last: Failure,
        failures: list[Failure],
        space: ConstraintSpace,
        ctx: Context,
    ) -> AnomalyReport:
        values = {**space.values(), **last.values}
        observations = tuple(_describe_observation(o) for o in ctx.belief.observations[-5:])
        return cls(
            action=spec.action,
            args=spec.args,
            steps=spec.steps,
            subtree=spec.label,
            sub_action=last.sub_action,
            constraint=last.constraint.atom(values),
            constraint_name=last.constraint.name,
            reason=last.reason,
            explored={k: tuple(v) for k, v in space.tried().items() if v},
            attempts=space.attempt,
            failures=dict(Counter(f.constraint.name for f in failures)),
            observations=observations,
            belief=tuple(sorted(ctx.belief.facts)),
            plan_atoms=spec.atoms,
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "action": self.action,
            "args": list(self.args),
            "steps": list(self.steps),
            "subtree": self.subtree,
            "sub_action": self.sub_action,
            "constraint": str(self.constraint),
            "constraint_name": self.constraint_name,
            "reason": self.reason,
            "explored": {k: list(v) for k, v in self.explored.items()},
            "attempts": self.attempts,
            "failures": dict(self.failures),
            "observations": list(self.observations),
            "belief": [str(a) for a in self.belief],
        }

    def dumps(self) -> str:
        return json.dumps(self.to_json(), indent=2)

    def describe(self) -> str:
        """A concise natural-language rendering for prompts."""
        explored = "; ".join(f"{k}: {_summary(v)}" for k, v in self.explored.items())
        return (
            f"While executing {self.action}({', '.join(self.args)}), step '{self.sub_action}' "
            f"could not be completed: the constraint {self.constraint} does not hold "
            f"({self.reason}). The robot explored {self.attempts} alternatives"
            + (f" ({explored})" if explored else "")
            + " without success."
        )


def _summary(values: tuple[str, ...]) -> str:
    """Distinct names listed; poses and other structured values only counted."""
    distinct = list(dict.fromkeys(v.strip("'") for v in values))
    if any("(" in v for v in distinct):
        return f"{len(distinct)} different value{'s' if len(distinct) != 1 else ''}"
    return ", ".join(distinct)


def _describe_observation(o: Any) -> str:
    seen = ", ".join(f"{d.obj} in {d.region}" for d in o.detections) or "nothing"
    return f"looked at {', '.join(o.viewed) or 'the current view'}: saw {seen}"
