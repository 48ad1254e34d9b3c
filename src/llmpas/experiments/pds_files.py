"""PDDLStream's own 2-D TAMP files planned by llmpas, with 2-D streams written here.

PDDLStream (GPL-3, not shipped) has ``examples/continuous_tamp/domain.pddl`` and ``stream.pddl``:
robots with suction grippers move width-2 blocks along a line; ``s-region`` samples poses in a
region, ``s-grasp`` gives the one top grasp, ``s-ik`` the gripper conf above a pose, ``s-motion`` a
path (up to travel height, across, down), ``t-cfree`` and ``t-region`` are tests, ``(Dist ?q1
?q2)`` costs 10 plus the L1 distance, ``(Cost)`` is 1 per pick or place. The files are read,
unchanged, from a directory the user gives (``llmpas bench tamp --pddlstream-files DIR``); this
module supplies the problems and the streams (its own code, written from the files' declarations
and the semantics stated here) and checks the plans.

Families (``make_instance``):

- ``mirror``: PDDLStream's own ``mirror`` problem: N blocks at x = -2, -5, -8, ..., each to the
  mirror image of its start pose; two robots at (-5, 6) and (5, 6), which must end where they
  started. The instance does not depend on the seed (only the samplers do).
- ``packed``: N slots in a row, each wider than one block and narrower than two; block i must end
  in slot i; for N >= 2 the blocks start in the slots permuted by one random cycle (so one block
  must first go to the free ground on the left); for N = 1 the block starts on the free ground.
  One robot at (-5, 6), which must end there.

An :class:`Instance` is plain data (floats and names), so that another planner can be given the
same problems.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.language.bindings import Implementation, cost, function, sampler, test
from llmpas.language.domain import read_domain
from llmpas.language.logic import Atom, FuncTerm
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.language.streams import read_streams
from llmpas.planning.result import Plan

FAMILIES = ("mirror", "packed")
BLOCK_WIDTH = 2.0
SUCTION = 1.0  # height of the suction cup
CARRY_Y = 2 * BLOCK_WIDTH + SUCTION  # travel height of the gripper
GRASP = (0.0, -(BLOCK_WIDTH + SUCTION / 2))  # block pose - gripper position
MOVE_COST = 10.0  # fixed part of (Dist ?q1 ?q2); the rest is the L1 distance
HOME = (-5.0, CARRY_Y + 1)
GROUND = "grey"
FILES = ("domain.pddl", "stream.pddl")

Point = tuple[float, float]


@dataclass(frozen=True)
class Instance:
    """One problem: start x of each block, its goal (an x or a region name), the regions
    (name -> (lo, hi)) and the robots' home confs (also their goal confs)."""

    family: str
    blocks: tuple[str, ...]
    start: tuple[float, ...]
    goals: tuple[float | str, ...]
    regions: Mapping[str, tuple[float, float]]
    robots: Mapping[str, Point]

    def __post_init__(self) -> None:
        if not len(self.blocks) == len(self.start) == len(self.goals):
            raise ValueError("an instance needs a start and a goal per block")
        if GROUND not in self.regions:
            raise ValueError(f"an instance needs the ground region {GROUND!r}")


def make_instance(family: str, n: int, seed: int) -> Instance:
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}; families are {', '.join(FAMILIES)}")
    if not 1 <= n <= 26:
        raise ValueError(f"the number of blocks must be in 1..26, got {n}")
    blocks = tuple(chr(ord("A") + i) for i in range(n))
    if family == "mirror":
        start = tuple(-((BLOCK_WIDTH + 1) * i + BLOCK_WIDTH) for i in range(n))
        robots = {"r0": HOME, "r1": (-HOME[0], HOME[1])}
        regions = {GROUND: (-10.0, 10.0), "red": (5.0, 10.0)}
        return Instance(family, blocks, start, tuple(-x for x in start), regions, robots)
    rng = np.random.default_rng([seed, 11])
    width = BLOCK_WIDTH * float(rng.uniform(1.1, 1.4))
    slots: dict[str, tuple[float, float]] = {}
    x = 0.0
    for i in range(n):
        slots[f"s{i + 1}"] = (round(x, 6), round(x + width, 6))
        x += width + float(rng.uniform(0.1, 0.4))
    regions = {GROUND: (-10.0, round(x + 1.0, 6)), **slots}
    names = list(slots)
    if n == 1:
        start = (round(float(rng.uniform(-8.0, -3.0)), 6),)
    else:
        cycle = [int(i) for i in rng.permutation(n)]  # block cycle[k] sits in slot cycle[k+1]
        where = {cycle[k]: cycle[(k + 1) % n] for k in range(n)}
        start = tuple(_inside(slots[names[where[i]]], rng) for i in range(n))
    return Instance(family, blocks, start, tuple(names), regions, {"r0": HOME})


def _inside(slot: tuple[float, float], rng: np.random.Generator) -> float:
    room = (slot[1] - slot[0] - BLOCK_WIDTH) / 2
    return round((slot[0] + slot[1]) / 2 + float(rng.uniform(-room, room)) * 0.5, 6)


# ----------------------------------------------------------------------------------- streams


def _interval(x: float) -> tuple[float, float]:
    return x - BLOCK_WIDTH / 2, x + BLOCK_WIDTH / 2


def cfree(b1: str, p1: Point, b2: str, p2: Point) -> bool:
    """Two blocks' footprints do not touch (a block never collides with itself)."""
    if b1 == b2:
        return True
    (lo1, hi1), (lo2, hi2) = _interval(p1[0]), _interval(p2[0])
    return hi1 < lo2 or hi2 < lo1


def contained(region: tuple[float, float], p: Point) -> bool:
    lo, hi = _interval(p[0])
    return region[0] <= lo and hi <= region[1]


def ik(p: Point, g: Point) -> Point:
    """The conf from which the gripper reaches a block at ``p`` with grasp ``g``: straight above
    the grasp point, at travel height above the block's pose."""
    return (p[0] - g[0], p[1] + CARRY_Y)


def motion(q1: Point, q2: Point) -> tuple[Point, ...]:
    return (q1, (q1[0], CARRY_Y), (q2[0], CARRY_Y), q2)


def distance(q1: Point, q2: Point) -> float:
    return MOVE_COST + abs(q2[0] - q1[0]) + abs(q2[1] - q1[1])


def duration(t: tuple[Point, ...]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(t)) / 4.0


def implementations(instance: Instance, seed: int) -> dict[str, Implementation]:
    rng = np.random.default_rng([seed, 7])
    regions = instance.regions

    def poses(b: str, r: str) -> Iterator[tuple[Point]]:
        lo, hi = regions[r][0] + BLOCK_WIDTH / 2, regions[r][1] - BLOCK_WIDTH / 2
        while lo <= hi:
            yield ((round(float(rng.uniform(lo, hi)), 6), 0.0),)

    return {
        "s-region": sampler(poses),
        "s-grasp": function(lambda b: (GRASP,)),
        "s-ik": function(lambda b, p, g: (ik(p, g),)),
        "s-motion": function(lambda q1, q2: (motion(q1, q2),)),
        "t-cfree": test(cfree),
        "t-region": test(lambda b, p, r: contained(regions[r], p), p_success=0),
        "dist": cost(distance, opt_fn=lambda q1, q2: MOVE_COST),
        "duration": cost(duration),
    }


# ---------------------------------------------------------------------------------- problems


def init_and_goal(instance: Instance) -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """Init facts and goal literals, as PDDLStream's example states its problems."""
    init: list[tuple[Any, ...]] = []
    goal: list[tuple[Any, ...]] = []
    for b, x, target in zip(instance.blocks, instance.start, instance.goals, strict=True):
        p = (x, 0.0)
        init += [("Block", b), ("Pose", b, p), ("AtPose", b, p), ("Placeable", b, GROUND)]
        if isinstance(target, str):
            init += [("Region", target), ("Placeable", b, target)]
            goal.append(("In", b, target))
        else:
            init.append(("Pose", b, (target, 0.0)))
            goal.append(("AtPose", b, (target, 0.0)))
    for r, q in instance.robots.items():
        init += [("Robot", r), ("CanMove", r), ("Conf", q), ("AtConf", r, q), ("HandEmpty", r)]
        goal.append(("AtConf", r, q))
    return init, goal


def check_files(directory: Path) -> Path:
    """``directory`` if it holds PDDLStream's 2-D ``domain.pddl`` and ``stream.pddl``; else
    ``ValueError`` naming what is missing."""
    missing = [f for f in FILES if not (directory / f).is_file()]
    if missing:
        raise ValueError(
            f"--pddlstream-files {directory}: no {missing[0]} (give PDDLStream's "
            "examples/continuous_tamp folder)"
        )
    return directory


def make_problem(directory: Path, family: str, n: int, seed: int) -> tuple[Instance, Problem]:
    instance = make_instance(family, n, seed)
    init, goal = init_and_goal(instance)
    problem = Problem.create(
        read_domain(directory / "domain.pddl"),
        read_streams(directory / "stream.pddl"),
        init=init,
        goal=goal,
        implementations=implementations(instance, seed),
        costs={("Cost",): 1.0},
        name=f"continuous-tamp-{family}-{n}",
    )
    return instance, problem


@dataclass(frozen=True)
class Checked:
    valid: bool
    message: str
    cost: float | None = None


def validate(instance: Instance, problem: Problem, plan: Plan) -> Checked:
    """Replay ``plan`` with llmpas's semantics from the init, the facts the streams certified
    but the tests (``CFree``, ``Contain`` recomputed here for every pose the plan mentions), and
    the distances recomputed from the confs; its cost is the replay's."""
    values = dict(problem.objects) | {k: v for k, v in plan.objects.items() if v is not None}
    if any(v is None for s in plan.steps for v in (values.get(a, a) for a in s.args)):
        return Checked(False, "a plan argument has no value")
    facts = set(problem.init) | {
        a for a in plan.certified if a.predicate not in ("cfree", "contain")
    }
    poses = sorted({a.args for a in facts if a.predicate == "pose"})
    facts |= {
        Atom("cfree", (b1, p1, b2, p2))
        for (b1, p1), (b2, p2) in itertools.product(poses, repeat=2)
        if cfree(b1, values[p1], b2, values[p2])
    }
    region_names = {v: k for k, v in values.items() if isinstance(v, str)}
    facts |= {
        Atom("contain", (b, p, s))
        for (b, p), (b2, s) in itertools.product(
            poses, sorted({a.args for a in facts if a.predicate == "placeable"})
        )
        if b == b2 and contained(instance.regions[values.get(s, region_names.get(s, s))], values[p])
    }
    costs: dict[FuncTerm, float] = dict(problem.costs)
    for step in plan.steps:
        if step.action == "move":
            q1, q2 = step.args[1], step.args[3]
            costs[FuncTerm("dist", (q1, q2))] = distance(values[q1], values[q2])
    names = set(values) | {t for a in facts for t in a.args}
    sem = Semantics(problem.domain, dict.fromkeys(names, "object"), costs)
    result = replay(sem, facts, [(s.action, s.args) for s in plan.steps], problem.goal)
    if not result.valid:
        return Checked(False, f"replay: {result.message}")
    return Checked(True, "ok", result.cost)


__all__ = [
    "FAMILIES",
    "Checked",
    "Instance",
    "check_files",
    "implementations",
    "init_and_goal",
    "make_instance",
    "make_problem",
    "validate",
]
