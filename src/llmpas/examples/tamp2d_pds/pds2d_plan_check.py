"""Checking a plan of the pds-tamp2d domain twice, independently of the planner.

1. Deferred stream instances are evaluated in plan order, as an executor would (a plan whose
   deferred IK or motion has no solution is invalid).
2. *Replay*: the plan is replayed with llmpas's PDDL semantics from the init, the facts the
   streams certified, and the test facts (``CFree``, ``Contain``) recomputed here for every pose
   the plan mentions (the planner's own test results are not trusted).
3. *Geometry*: the plan is simulated on the real values: every move follows its trajectory from
   the robot's conf to the next (points ``RESOLUTION`` apart: gripper and held block clear of the
   standing blocks, the walls, the ground and the other robots); every pick and place is at the
   conf its grasp puts the gripper, on the block's top face; placed blocks stand on the ground
   and overlap nothing; at the end every block is at its goal pose or inside its goal region and
   every robot is home with an empty hand.

Robots are also checked against each other (gripper and held block), which the domain does not
model (as in PDDLStream's example): a plan can replay and still fail here.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from llmpas.examples.tamp2d_pds.pds2d_geometry import (
    GRIPPER_HALF,
    Block,
    Conf,
    Grasp,
    Pose,
    Rect,
    Traj,
    close,
    grasp_conf,
    gripper_rect,
    held_pose,
    overlaps,
    sample_path,
    swept_hits,
)
from llmpas.examples.tamp2d_pds.pds2d_streams import distance, test_cfree, test_contain
from llmpas.examples.tamp2d_pds.pds2d_world import Scene
from llmpas.language.logic import Atom, FuncTerm
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.planning.result import Plan

TEST_PREDICATES = ("cfree", "contain")
Step = tuple[str, tuple[str, ...]]


@dataclass(frozen=True)
class Validation:
    """``valid`` with ``message`` "ok", or the first problem found (``stage``: deferred, replay
    or geometry)."""

    valid: bool
    message: str
    stage: str = ""
    deferred_evaluated: int = 0
    cost: float | None = None  # the plan's cost on the real values (replay), when it replays

    def __post_init__(self) -> None:
        if self.valid != (self.message == "ok"):
            raise ValueError("a valid plan has the message 'ok', an invalid one its reason")


class Invalid(Exception):
    """A plan failed a check (internal: becomes an invalid :class:`Validation`)."""


def validate(world: Scene, problem: Problem, plan: Plan) -> Validation:
    """Evaluate ``plan``'s deferred streams, then replay it and simulate it (module docstring)."""
    try:
        values = complete_values(problem, plan)
    except Invalid as e:
        return Validation(False, str(e), "deferred")
    steps: list[Step] = [(s.action, s.args) for s in plan.steps]
    n = len(plan.deferred)
    try:
        cost = check_replay(world, problem, plan, steps, values)
    except Invalid as e:
        return Validation(False, str(e), "replay", n)
    try:
        check_geometry(world, problem, plan, steps, values)
    except Invalid as e:
        return Validation(False, str(e), "geometry", n, cost)
    return Validation(True, "ok", "", n, cost)


def complete_values(problem: Problem, plan: Plan) -> dict[str, Any]:
    """Object values with every deferred placeholder filled by evaluating its stream on the
    values of its inputs, in the order the plan needs them."""
    values = dict(problem.objects) | {k: v for k, v in plan.objects.items() if v is not None}
    for inst in plan.deferred:
        missing = [x for x in inst.inputs if values.get(x) is None]
        if missing:
            raise Invalid(f"deferred {inst}: input {missing[0]} has no value")
        bound = problem.bound_streams[inst.stream]
        out = next(iter(bound.outputs(tuple(values[x] for x in inst.inputs))), None)
        if out is None:
            raise Invalid(f"deferred {inst}: the stream has no output")
        values.update(zip(inst.outputs, out, strict=True))
    return values


# ------------------------------------------------------------------------------------ replay


def check_replay(
    world: Scene, problem: Problem, plan: Plan, steps: list[Step], values: Mapping[str, Any]
) -> float:
    """The plan's cost, replayed on the real values; :class:`Invalid` if it does not replay."""
    claimed = {a for a in plan.certified if a.predicate not in TEST_PREDICATES}
    facts = set(problem.init) | claimed
    facts |= recomputed_tests(world, facts, values)
    costs: dict[FuncTerm, float] = dict(problem.costs)
    for name, args in steps:
        if name == "move":
            q1, q2 = args[1], args[3]
            costs[FuncTerm("dist", (q1, q2))] = distance(world, values[q1], values[q2])
    names = set(values) | {t for a in facts for t in a.args}
    sem = Semantics(problem.domain, dict.fromkeys(names, "object"), costs)
    result = replay(sem, facts, steps, problem.goal)
    if not result.valid:
        raise Invalid(f"replay: {result.message}")
    return result.cost


def recomputed_tests(world: Scene, facts: set[Atom], values: Mapping[str, Any]) -> set[Atom]:
    """``CFree`` for every pair of (block, pose) in ``facts``, ``Contain`` for every pose and
    region its block may be put in, computed with this module's geometry."""
    poses = sorted({a.args for a in facts if a.predicate == "pose"})
    out = {
        Atom("cfree", (b1, p1, b2, p2))
        for (b1, p1), (b2, p2) in itertools.product(poses, repeat=2)
        if test_cfree(world, b1, values[p1], b2, values[p2])
    }
    placeable = sorted({a.args for a in facts if a.predicate == "placeable"})
    out |= {
        Atom("contain", (b, p, s))
        for (b, p), (b2, s) in itertools.product(poses, placeable)
        if b == b2 and test_contain(world, b, values[p], s)
    }
    return out


# ---------------------------------------------------------------------------------- geometry


@dataclass
class _Scene:
    """The simulated world during a geometric check."""

    world: Scene
    poses: dict[str, Pose]  # blocks standing on the ground
    confs: dict[str, Conf]
    held: dict[str, tuple[str, Grasp] | None]

    def standing(self, but: str | None = None) -> list[Rect]:
        w = self.world
        return [w.block(b).rect(p) for b, p in sorted(self.poses.items()) if b != but]

    def other_robots(self, r: str) -> list[Rect]:
        """The grippers of the robots other than ``r``, and the blocks they hold."""
        out = []
        for other, q in sorted(self.confs.items()):
            if other == r:
                continue
            out.append(gripper_rect(q))
            held = self.held[other]
            if held is not None:
                out.append(self.world.block(held[0]).rect(held_pose(q, held[1])))
        return out


def check_geometry(
    world: Scene, problem: Problem, plan: Plan, steps: list[Step], values: Mapping[str, Any]
) -> None:
    scene = _Scene(
        world,
        {b.name: p for b, p in zip(world.blocks, world.start, strict=True)},
        dict(zip(world.robots, world.homes, strict=True)),
        dict.fromkeys(world.robots),
    )
    for k, (name, args) in enumerate(steps, 1):
        vals = [values.get(a, a) for a in args]
        try:
            ACTIONS[name](scene, *vals)
        except KeyError:
            raise Invalid(f"geometry: step {k}: unknown action {name!r}") from None
        except Invalid as e:
            raise Invalid(f"geometry: step {k} ({name} {' '.join(args)}): {e}") from None
    _check_goal(scene)


def _robot(scene: _Scene, r: Any) -> str:
    if r not in scene.confs:
        raise Invalid(f"{r!r} is not a robot")
    return str(r)


def _move(scene: _Scene, r: Any, q1: Any, t: Any, q2: Any) -> None:
    r = _robot(scene, r)
    if not (isinstance(t, Traj) and isinstance(q1, Conf) and isinstance(q2, Conf)):
        raise Invalid("a move needs two confs and a trajectory")
    if not t.waypoints or not close(scene.confs[r], q1) or not close(t.waypoints[0], q1):
        raise Invalid("the trajectory does not start where the robot is")
    if not close(t.waypoints[-1], q2):
        raise Invalid("the trajectory does not end at the target conf")
    pts = sample_path(t.waypoints)
    obstacles = [*scene.world.obstacles, *scene.standing(), *scene.other_robots(r)]
    if swept_hits(pts, GRIPPER_HALF, obstacles).any():
        raise Invalid("the gripper collides on the way")
    if (pts[:, 1] - GRIPPER_HALF[1] < -1e-6).any():
        raise Invalid("the gripper goes below the ground")
    held = scene.held[r]
    if held is not None:
        b, g = scene.world.block(held[0]), held[1]
        centres = pts - (g.dx, g.dy)
        if swept_hits(centres, (b.width / 2, b.height / 2), obstacles).any():
            raise Invalid(f"the held block {b.name} collides on the way")
        if (centres[:, 1] - b.height / 2 < -1e-6).any():
            raise Invalid(f"the held block {b.name} goes below the ground")
    scene.confs[r] = q2


def _at_grasp(scene: _Scene, r: str, p: Any, g: Any, q: Any) -> None:
    if not (isinstance(p, Pose) and isinstance(g, Grasp) and isinstance(q, Conf)):
        raise Invalid("a pick or place needs a pose, a grasp and a conf")
    if not close(scene.confs[r], q):
        raise Invalid("the robot is not at the conf of the step")
    if not close(grasp_conf(p, g), q):
        raise Invalid("the conf does not hold the block at the pose with the grasp")


def _check_grasp(block: Block, g: Grasp) -> None:
    """Suction on the top face: the gripper rests on it and does not overhang it."""
    on_top = abs(g.dy - (block.height / 2 + GRIPPER_HALF[1])) <= 1e-6
    if not on_top or abs(g.dx) + GRIPPER_HALF[0] > block.width / 2 + 1e-6:
        raise Invalid(f"the grasp is not on the top face of {block.name}")


def _pick(scene: _Scene, r: Any, b: Any, p: Any, g: Any, q: Any) -> None:
    r = _robot(scene, r)
    _at_grasp(scene, r, p, g, q)
    if scene.held[r] is not None:
        raise Invalid("the gripper is not empty")
    if b not in scene.poses or not close(scene.poses[b], p):
        raise Invalid(f"block {b} is not at the pose")
    _check_grasp(scene.world.block(b), g)
    del scene.poses[b]
    scene.held[r] = (b, g)


def _place(scene: _Scene, r: Any, b: Any, p: Any, g: Any, q: Any) -> None:
    r = _robot(scene, r)
    _at_grasp(scene, r, p, g, q)
    held = scene.held[r]
    if held is None or held[0] != b or held[1] != g:
        raise Invalid(f"the robot does not hold {b} with that grasp")
    block = scene.world.block(b)
    if not scene.world.ground.contains(block, p):
        raise Invalid(f"{b} would not stand on the ground")
    rect = block.rect(p)
    if any(overlaps(rect, o) for o in (*scene.world.obstacles, *scene.standing())):
        raise Invalid(f"{b} would overlap a wall or another block")
    if any(overlaps(rect, o) for o in scene.other_robots(r)):
        raise Invalid(f"{b} would overlap another robot or the block it holds")
    scene.poses[b] = p
    scene.held[r] = None


ACTIONS: dict[str, Callable[..., None]] = {"move": _move, "pick": _pick, "place": _place}


def _check_goal(scene: _Scene) -> None:
    w = scene.world
    for b, goal in zip(w.blocks, w.goals, strict=True):
        p = scene.poses.get(b.name)
        if p is None:
            raise Invalid(f"geometry: {b.name} is not standing at the end")
        ok = close(p, goal) if isinstance(goal, Pose) else goal.contains(b, p)
        if not ok:
            raise Invalid(f"geometry: {b.name} does not reach its goal")
    for r, home in zip(w.robots, w.homes, strict=True):
        if scene.held[r] is not None or not close(scene.confs[r], home):
            raise Invalid(f"geometry: robot {r} is not home with an empty hand at the end")


__all__ = ["Invalid", "Validation", "check_geometry", "check_replay", "complete_values", "validate"]
