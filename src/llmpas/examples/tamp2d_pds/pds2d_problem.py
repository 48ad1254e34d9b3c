"""pds-tamp2d problems: the init and goal of a :class:`Scene`, bound to the streams."""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

import numpy as np

from llmpas.examples._files import load_domain, load_streams
from llmpas.examples.tamp2d_pds.pds2d_geometry import Pose
from llmpas.examples.tamp2d_pds.pds2d_streams import DEFERRABLE, implementations
from llmpas.examples.tamp2d_pds.pds2d_world import Scene, make_world
from llmpas.language.problem import Problem

PACKAGE = "llmpas.examples.tamp2d_pds"
MANIPULATION_COST = 1.0  # (Cost): the cost of a pick or a place

Fact = tuple[Any, ...]


def init_facts(world: Scene) -> list[Fact]:
    """Robots at home with empty hands; blocks at their start poses; where each may be put."""
    facts: list[Fact] = []
    for r, q in zip(world.robots, world.homes, strict=True):
        facts += [("Robot", r), ("Conf", q), ("AtConf", r, q), ("HandEmpty", r), ("CanMove", r)]
    facts += [("Region", s.name) for s in (world.ground, *world.regions)]
    for b, p, goal in zip(world.blocks, world.start, world.goals, strict=True):
        facts += [("Block", b.name), ("Pose", b.name, p), ("AtPose", b.name, p)]
        facts.append(("Placeable", b.name, world.ground.name))
        if isinstance(goal, Pose):
            facts.append(("Pose", b.name, goal))
        else:
            facts.append(("Placeable", b.name, goal.name))
    return facts


def goal_facts(world: Scene) -> list[Fact]:
    """Every block at its goal pose or in its goal region; every robot home, its hand empty."""
    goals: list[Fact] = [
        ("AtPose", b.name, g) if isinstance(g, Pose) else ("In", b.name, g.name)
        for b, g in zip(world.blocks, world.goals, strict=True)
    ]
    for r, q in zip(world.robots, world.homes, strict=True):
        goals += [("AtConf", r, q), ("HandEmpty", r)]
    return goals


def problem_for(world: Scene, seed: int, deferred: Collection[str] = DEFERRABLE) -> Problem:
    """The planning problem of ``world``; samplers draw from an rng seeded with ``seed``.
    ``deferred`` streams are marked deferred (used when the planner's ``defer`` is on)."""
    rng = np.random.default_rng([seed, 7])
    return Problem.create(
        load_domain(PACKAGE),
        load_streams(PACKAGE),
        init=init_facts(world),
        goal=goal_facts(world),
        implementations=implementations(world, rng, deferred),
        costs={("Cost",): MANIPULATION_COST},
        name=f"pds-{world.family}-{len(world.blocks)}",
    )


def make_problem(
    family: str, n_blocks: int, seed: int, deferred: Collection[str] = DEFERRABLE
) -> tuple[Scene, Problem]:
    """The world of ``family`` with ``n_blocks`` blocks generated from ``seed``, and its problem."""
    world = make_world(family, n_blocks, seed)
    return world, problem_for(world, seed, deferred)


__all__ = [
    "MANIPULATION_COST",
    "PACKAGE",
    "goal_facts",
    "init_facts",
    "make_problem",
    "problem_for",
]
