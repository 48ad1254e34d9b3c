"""A world's tables for the reasoner, as data, and the one place a prompt's situation is built.

A world hands over :class:`PromptTables` (what each action does and makes true, what each goal
predicate means, the actions as skill calls for ProgPrompt and Inner-Monologue, the objects);
:func:`situation` renders them with the anomaly, the believed environment and the task.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from llmpas.language.logic import Formula
from llmpas.reasoning.methods import Situation
from llmpas.reasoning.program import Call


@dataclass(frozen=True)
class PromptTables:
    """``actions``: name -> (what it does, predicates it makes true); ``predicates``: name ->
    (parameters, meaning); ``calls``: the actions as functions; ``objects``: the scenario's
    objects (for program-style prompts)."""

    actions: Mapping[str, tuple[str, tuple[str, ...]]]
    predicates: Mapping[str, tuple[str, str]]
    calls: Mapping[str, Call] = field(default_factory=dict)
    objects: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.actions or not self.predicates:
            raise ValueError("prompt tables need at least one action and one predicate")
        for name, call in self.calls.items():
            if call.predicate not in self.predicates:
                raise ValueError(f"call {name!r} makes {call.predicate!r}, not a listed predicate")
        object.__setattr__(self, "actions", MappingProxyType(dict(self.actions)))
        object.__setattr__(self, "predicates", MappingProxyType(dict(self.predicates)))
        object.__setattr__(self, "calls", MappingProxyType(dict(self.calls)))

    def action_library(self) -> str:
        lines = []
        for name, (text, makes) in self.actions.items():
            made = f" — makes true: {', '.join(makes)}" if makes else ""
            lines.append(f"- {name}: {text}{made}")
        return "\n".join(lines)

    def predicate_list(self) -> str:
        return "\n".join(f"- ({n} {args}): {text}" for n, (args, text) in self.predicates.items())


def situation(
    tables: PromptTables,
    anomaly: str,
    environment: str,
    task: str,
    history: str = "",
    constraint: Formula | None = None,
) -> Situation:
    """What a prompt may show about one anomaly (``anomaly``: its sentence; ``constraint``: the
    failed literal, carried as data for backends that read it, never shown twice)."""
    return Situation(
        anomaly=anomaly,
        actions=tables.action_library(),
        predicates=tables.predicate_list(),
        environment=environment,
        task=f"the robot must achieve {task}",
        history=history,
        calls=tables.calls,
        objects=tables.objects,
        constraint=constraint,
    )


__all__ = ["PromptTables", "situation"]
