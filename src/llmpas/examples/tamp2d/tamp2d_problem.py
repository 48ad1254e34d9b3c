"""tamp2d problems: init and goal facts of a :class:`Scene` and the bound :class:`Problem`."""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

import numpy as np

from llmpas.examples._files import load_domain, load_streams
from llmpas.examples.tamp2d.tamp2d_streams import implementations
from llmpas.examples.tamp2d.tamp2d_world import Scene, make_world
from llmpas.language.problem import Problem

PACKAGE = "llmpas.examples.tamp2d"

Fact = tuple[Any, ...]


def init_facts(world: Scene) -> list[Fact]:
    """The start state: blocks at their start poses, the gripper empty at home."""
    facts: list[Fact] = [("Conf", world.home), ("AtConf", world.home), ("HandEmpty",), ("CanMove",)]
    facts += [("Region", r.name) for r in (world.table, *world.regions)]
    for b, p, goal in zip(world.blocks, world.start, world.regions, strict=True):
        facts += [("Block", b.name), ("Pose", b.name, p), ("AtPose", b.name, p)]
        facts += [("Placeable", b.name, world.table.name), ("Placeable", b.name, goal.name)]
        facts += [
            ("Contain", b.name, p, r.name)
            for r in (world.table, *world.regions)
            if r.contains(b, p)
        ]
    return facts


def goal_facts(world: Scene) -> list[Fact]:
    """Every block inside its own goal region, and the gripper back home."""
    goals: list[Fact] = [
        ("In", b.name, r.name) for b, r in zip(world.blocks, world.regions, strict=True)
    ]
    return [*goals, ("AtConf", world.home)]


DEFAULT_DEFERRED = ("inverse-kinematics", "plan-motion")  # the gripper's geometry: for execution


def make_problem(
    n_blocks: int, seed: int, defer_streams: Collection[str] = DEFAULT_DEFERRED
) -> Problem:
    """``n_blocks`` blocks, each with its own goal region; about half of the blocks start inside
    another block's goal region, so blocks often have to be moved aside first."""
    world = make_world(n_blocks, seed)
    rng = np.random.default_rng([seed, 1])
    return Problem.create(
        load_domain(PACKAGE),
        load_streams(PACKAGE),
        init=init_facts(world),
        goal=goal_facts(world),
        implementations=implementations(world, rng, defer_streams),
        name=f"tamp2d-{n_blocks}-{seed}",
    )
