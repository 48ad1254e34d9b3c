"""Labelled oracles: goals computed from a world's TRUE state, used only as an upper bound (never
as a default). Each implements the LLM protocol and reads the anomaly from the request
(``request.situation.constraint``) like every backend reads it from the prompt."""

from __future__ import annotations

from llmpas.language.logic import Atom, Formula, Not
from llmpas.reasoning.llm import Request, Response

FIRST_LOOK = "Look where the truth says."


def failed_literal(request: Request) -> Formula | None:
    """The anomaly's failed literal carried by the request (None: not a goal request)."""
    situation = request.situation
    if request.tag == "first-look" or situation is None:
        return None
    constraint: Formula | None = getattr(situation, "constraint", None)
    return constraint


def answer(goals: list[Atom | Not]) -> Response:
    return Response(f"(and {' '.join(map(str, goals))})", model="oracle")


def first_look() -> Response:
    return Response(FIRST_LOOK, model="oracle")


__all__ = ["FIRST_LOOK", "answer", "failed_literal", "first_look"]
