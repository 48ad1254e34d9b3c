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


class TruthOracle:
    """The shape every world's oracle shares: a short first look, then goals for the failed
    literal the request carries (:meth:`goals_for` the literal's atom; ``negated``: it failed
    as ``(not atom)``), computed from the world's truth by the subclass."""

    name = "oracle"

    def complete(self, request: Request) -> Response:
        c = failed_literal(request)
        if c is None:
            return first_look()
        atom = c.arg if isinstance(c, Not) else c
        goals = self.goals_for(atom, isinstance(c, Not)) if isinstance(atom, Atom) else []
        return answer(goals)

    def goals(self, c: Formula) -> list[Atom | Not]:
        atom = c.arg if isinstance(c, Not) else c
        return self.goals_for(atom, isinstance(c, Not)) if isinstance(atom, Atom) else []

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        raise NotImplementedError


def answer(goals: list[Atom | Not]) -> Response:
    return Response(f"(and {' '.join(map(str, goals))})", model="oracle")


def first_look() -> Response:
    return Response(FIRST_LOOK, model="oracle")


__all__ = ["FIRST_LOOK", "TruthOracle", "answer", "failed_literal", "first_look"]
