"""The believed state and the planning problem as every kitchen world builds them: objects at
their believed poses, the base at its start, the hand empty; a problem over the kitchen domain
from the believed facts, the values they name, and a world's stream implementations."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from llmpas.execution.context import Belief
from llmpas.language.domain import Domain
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.worlds.kitchen import load_domain, load_streams
from llmpas.worlds.kitchen.belief import rests_at
from llmpas.worlds.kitchen.kitchen_values import BaseConf


def start_belief(static: set[Atom], poses: Mapping[str, Any], base: BaseConf) -> Belief:
    """The static facts, each object at its pose (None: unknown), the base at ``base`` (named
    ``q0``), the hand empty and the base free to move."""
    belief = Belief(static, {})
    for obj, pose in poses.items():
        rests_at(belief, obj, pose)
    q = belief.name("q0", base)
    belief.facts |= {
        Atom("bconf", (q,)),
        Atom("atbconf", (q,)),
        Atom("handempty", ()),
        Atom("canmove", ()),
    }
    return belief


def kitchen_problem(
    facts: set[Atom],
    belief: Belief,
    goal: Formula | str,
    implementations: Mapping[str, Any],
    name: str,
    domain: Domain | None = None,
) -> Problem:
    """The problem from ``facts`` (the believed ones and any a world adds), with the believed
    values they name as objects."""
    used = {t for a in facts for t in a.args}
    values: dict[str, Any] = {n: v for n, v in belief.values.items() if n in used}
    return Problem.create(
        domain or load_domain(),
        load_streams(),
        init=sorted(facts),
        goal=goal,
        implementations=implementations,
        objects=values,
        name=name,
    )


__all__ = ["kitchen_problem", "start_belief"]
