"""A world's tables for the reasoner, as data, and the one place a prompt's situation is built.

A world hands over :class:`PromptTables` (what each action does and makes true, what each goal
predicate means, the actions as skill calls for ProgPrompt and Inner-Monologue, the objects);
:func:`situation` renders them with the anomaly, the believed environment and the task.
"""

from __future__ import annotations

from llmpas.language.logic import Formula
from llmpas.reasoning.methods import Situation
from llmpas.reasoning.tables import PromptTables


def situation(
    tables: PromptTables,
    anomaly: str,
    environment: str,
    task: str,
    history: str = "",
    constraint: Formula | None = None,
    intent: str = "",
) -> Situation:
    """What a prompt may show about one anomaly (``anomaly``: its sentence; ``constraint``: the
    failed literal, carried as data for backends that read it, never shown twice; ``intent``: the
    task's intent when the run has one, as data, never shown)."""
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
        intent=intent,
    )


__all__ = ["PromptTables", "situation"]
