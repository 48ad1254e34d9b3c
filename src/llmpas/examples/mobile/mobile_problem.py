"""Kitchen problems: init and goal facts of a :class:`Kitchen` and the bound :class:`Problem`."""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

import numpy as np

from llmpas.examples._files import load_domain, load_streams
from llmpas.examples.mobile.mobile_streams import DEFAULT_DEFERRED, StreamParams, implementations
from llmpas.examples.mobile.mobile_world import Goal, Kitchen, make_kitchen
from llmpas.language.problem import Problem

PACKAGE = "llmpas.examples.mobile"
ARM = "arm"

Fact = tuple[Any, ...]


def init_facts(kitchen: Kitchen) -> list[Fact]:
    """The start state: objects on tables, the hand empty, the base at home."""
    facts: list[Fact] = [("Arm", ARM), ("HandEmpty", ARM), ("CanMove",)]
    facts += [("BConf", kitchen.home), ("AtBConf", kitchen.home)]
    for s in kitchen.surfaces:
        facts.append(("Region", s.name))
        if s.kind == "sink":
            facts.append(("Sink", s.name))
        elif s.kind == "stove":
            facts.append(("Stove", s.name))
    for o, p, where in zip(kitchen.objects, kitchen.start, kitchen.start_surface, strict=True):
        facts += [("Object", o.name), ("Pose", o.name, p), ("AtPose", o.name, p)]
        facts.append(("Supported", o.name, p, where))
        facts += [("Stackable", o.name, s.name) for s in kitchen.surfaces]
    return facts


def goal_fact(goal: Goal) -> Fact:
    if goal.kind == "on":
        return ("On", goal.obj, goal.region)
    return ("Cleaned" if goal.kind == "cleaned" else "Cooked", goal.obj)


def goal_facts(kitchen: Kitchen) -> list[Fact]:
    return [goal_fact(g) for g in kitchen.goals]


def make_problem(
    n_objects: int,
    seed: int,
    defer_streams: Collection[str] = DEFAULT_DEFERRED,
    params: StreamParams | None = None,
) -> Problem:
    """A kitchen with ``n_objects`` objects, each with a goal (on another table, cleaned, or
    cooked). ``defer_streams`` names the streams left for the executor (``()``: none)."""
    kitchen = make_kitchen(n_objects, seed)
    rng = np.random.default_rng([seed, 1])
    return Problem.create(
        load_domain(PACKAGE),
        load_streams(PACKAGE),
        init=init_facts(kitchen),
        goal=goal_facts(kitchen),
        implementations=implementations(kitchen, rng, defer_streams, params),
        name=f"kitchen-{n_objects}-{seed}",
    )
