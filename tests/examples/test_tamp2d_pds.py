"""The pds-tamp2d domain: files, generation, streams, planning and the plan validator."""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import numpy as np
import pytest

from llmpas.examples.tamp2d_pds import FAMILIES, STREAM_NAMES, make_problem, make_world
from llmpas.examples.tamp2d_pds import pds2d_streams as st
from llmpas.examples.tamp2d_pds.pds2d_geometry import (
    Conf,
    Grasp,
    Pose,
    Traj,
    grasp_conf,
    gripper_rect,
    overlaps,
)
from llmpas.examples.tamp2d_pds.pds2d_plan_check import Invalid, check_geometry, validate
from llmpas.examples.tamp2d_pds.pds2d_world import Scene
from llmpas.language.logic import And, Atom, Exists, Forall, Formula, Not, Or
from llmpas.language.semantics import nnf
from llmpas.planning import PlannerConfig, solve
from llmpas.planning.result import Plan

SEEDS = (0, 1, 2)


def test_files_load_with_positive_only_tests_and_a_forall_place() -> None:
    _, p = make_problem("mirror", 1, 0)
    assert [s.name for s in p.streams.streams] == list(STREAM_NAMES)
    assert [f.name for f in p.streams.functions] == ["dist"]
    assert p.streams.stream("test-cfree").is_test and p.streams.stream("test-contain").is_test
    place = p.domain.action("place")
    assert "forall" in str(place.precondition).lower()
    formulas = [a.precondition for a in p.domain.actions] + [d.body for d in p.domain.derived]
    negated = {a.predicate for f in formulas for a in _negated_atoms(nnf(f))}
    assert negated == {"pose", "atpose"}  # only the implication's antecedent, after NNF
    assert not negated & {"cfree", "contain"}


def _negated_atoms(f: Formula) -> list[Atom]:
    match f:
        case Not(Atom() as a):
            return [a]
        case And(parts) | Or(parts):
            return [a for x in parts for a in _negated_atoms(x)]
        case Exists(_, body) | Forall(_, body):
            return _negated_atoms(body)
    return []


@pytest.mark.parametrize(("family", "n", "seed"), itertools.product(FAMILIES, (1, 2, 5, 8), SEEDS))
def test_generated_worlds_are_consistent(family: str, n: int, seed: int) -> None:
    w = make_world(family, n, seed)
    assert make_world(family, n, seed) == w  # seeded
    assert len(w.blocks) == len(w.start) == len(w.goals) == n
    rects = [b.rect(p) for b, p in zip(w.blocks, w.start, strict=True)]
    for r1, r2 in itertools.combinations(rects, 2):
        assert not overlaps(r1, r2)
    for b, p, g in zip(w.blocks, w.start, w.goals, strict=True):
        assert w.ground.contains(b, p)
        assert not any(overlaps(b.rect(p), o) for o in w.obstacles)
        done = p == g if isinstance(g, Pose) else g.contains(b, p)
        assert not done  # nothing starts at its goal
    for home in w.homes:
        assert not any(overlaps(gripper_rect(home), o) for o in w.obstacles)


def test_seeds_give_different_worlds() -> None:
    for family in FAMILIES:
        assert len({make_world(family, 3, s) for s in range(5)}) == 5


def test_mirror_goals_mirror_the_starts_across_the_wall() -> None:
    w = make_world("mirror", 4, 0)
    (wall,) = w.obstacles
    assert len(w.robots) == 2
    for p, g in zip(w.start, w.goals, strict=True):
        assert isinstance(g, Pose) and g == Pose(-p.x, p.y) and p.x < wall.x0


@pytest.mark.parametrize("n", [2, 3, 6])
def test_packed_starts_form_one_cycle_and_fill_every_slot(n: int) -> None:
    w = make_world("packed", n, 1)
    inside = {}
    for i, (b, p) in enumerate(zip(w.blocks, w.start, strict=True)):
        (slot,) = [k for k, s in enumerate(w.regions) if s.contains(b, p)]
        assert slot != i
        inside[i] = slot
    assert sorted(inside.values()) == list(range(n))  # every slot taken
    k, seen = 0, set()
    while k not in seen:  # one cycle through every block
        seen.add(k)
        k = inside[k]
    assert len(seen) == n
    narrowest = min(b.width for b in w.blocks)
    assert all(s.hi - s.lo < 2 * narrowest for s in w.regions)  # one block per slot


def test_bad_generation_arguments() -> None:
    with pytest.raises(ValueError, match="unknown family"):
        make_world("spiral", 2, 0)
    with pytest.raises(ValueError, match="number of blocks"):
        make_world("mirror", 0, 0)
    with pytest.raises(ValueError, match="unknown stream"):
        st.implementations(make_world("mirror", 1, 0), np.random.default_rng(0), ("teleport",))


# ------------------------------------------------------------------------------------ streams


def test_samplers_stay_in_their_region_and_off_the_wall() -> None:
    w = make_world("mirror", 3, 0)
    rng = np.random.default_rng(0)
    b = w.blocks[0]
    poses = [p for (p,) in itertools.islice(st.sample_pose(w, rng, b.name, "ground"), 300)]
    assert len(set(poses)) == 300
    assert all(w.ground.contains(b, p) for p in poses)
    assert not any(overlaps(b.rect(p), w.obstacles[0]) for p in poses)
    grasps = [g for (g,) in itertools.islice(st.sample_grasp(w, rng, b.name), 50)]
    assert grasps[0] == Grasp(0.0, b.height / 2 + 0.15)
    for g in grasps:  # the gripper stays on the top face
        assert abs(g.dx) + 0.2 <= b.width / 2


def test_inverse_kinematics_and_its_refusals() -> None:
    w = make_world("mirror", 2, 0)
    b = w.blocks[0]
    g = Grasp(0.1, b.height / 2 + 0.15)
    (q,) = st.inverse_kinematics(w, b.name, w.start[0], g) or ()
    assert q == Conf(w.start[0].x + 0.1, w.start[0].y + g.dy)
    assert st.inverse_kinematics(w, b.name, b.resting(0.0), g) is None  # into the wall
    assert st.inverse_kinematics(w, b.name, b.resting(w.ground.hi + 5), g) is None


def test_plan_motion_goes_over_the_wall() -> None:
    w = make_world("mirror", 2, 0)
    q1, q2 = Conf(-3.0, 1.0), Conf(3.0, 1.0)
    (t,) = st.plan_motion(w, q1, q2) or ()
    assert t.waypoints[0] == q1 and t.waypoints[-1] == q2
    assert max(q.y for q in t.waypoints) == w.carry > w.obstacles[0].y1
    assert st.distance(w, q1, q2) == pytest.approx(1.0 + t.length)
    assert st.plan_motion(w, q1, Conf(0.0, 0.5)) is None  # a conf inside the wall
    assert st.plan_motion(w, q1, Conf(w.ground.hi + 1, 1.0)) is None


def test_cfree_and_contain() -> None:
    w = make_world("packed", 2, 0)
    b1, b2 = w.blocks
    p = b1.resting(2.0)
    assert not st.test_cfree(w, b1.name, p, b2.name, b2.resting(2.0 + b1.width / 2))
    assert st.test_cfree(w, b1.name, p, b2.name, b2.resting(2.0 + (b1.width + b2.width) / 2))
    assert st.test_cfree(w, b1.name, p, b1.name, p)
    slot = w.regions[0]
    assert st.test_contain(w, b1.name, b1.resting((slot.lo + slot.hi) / 2), slot.name)
    assert not st.test_contain(w, b1.name, b1.resting(slot.lo), slot.name)


# ------------------------------------------------------------------------------- plan + check


def _plan(family: str, n: int, defer: bool) -> tuple[object, object, Plan]:
    w, p = make_problem(family, n, 0)
    result = solve(p, PlannerConfig(defer=defer, max_time=60, search_time=60))
    assert result.plan is not None, result.message
    return w, p, result.plan


@pytest.mark.parametrize(
    ("family", "n", "defer"),
    [("mirror", 1, False), ("packed", 1, False), ("mirror", 2, True), ("packed", 2, True)],
)
def test_plans_validate(family: str, n: int, defer: bool) -> None:
    w, p, plan = _plan(family, n, defer)
    check = validate(w, p, plan)  # type: ignore[arg-type]
    assert check.valid, check.message
    assert (check.deferred_evaluated > 0) == defer
    picks = [s for s in plan.steps if s.action == "pick"]
    assert len(picks) >= n + (family == "packed" and n > 1)  # packed: one block moves twice


@pytest.fixture(scope="module")
def packed2() -> tuple[object, object, Plan]:
    return _plan("packed", 2, True)


def test_a_truncated_plan_fails(packed2: tuple[object, object, Plan]) -> None:
    w, p, plan = packed2
    short = dataclasses.replace(plan, steps=plan.steps[:-2])
    check = validate(w, p, short)  # type: ignore[arg-type]
    assert not check.valid and check.stage == "replay" and "goal" in check.message


def test_a_place_onto_another_block_fails(packed2: tuple[object, object, Plan]) -> None:
    w, p, plan = packed2
    k, place = next((k, s) for k, s in enumerate(plan.steps) if s.action == "place")
    other = next(b for b in w.blocks if b.name != place.args[1])  # type: ignore[attr-defined]
    where = w.start[w.blocks.index(other)]  # type: ignore[attr-defined]
    block = w.block(place.args[1])  # type: ignore[attr-defined]
    objects = dict(plan.objects)
    objects[place.args[2]] = block.resting(where.x)
    bad = dataclasses.replace(plan, objects=objects)
    check = validate(w, p, bad)  # type: ignore[arg-type]
    assert not check.valid, k
    assert check.stage in ("replay", "geometry")


def test_a_trajectory_through_the_wall_fails_only_the_geometry() -> None:
    w, p, plan = _plan("mirror", 1, False)
    objects = dict(plan.objects)
    last_place = max(k for k, s in enumerate(plan.steps) if s.action == "place")
    carry = [s for s in plan.steps[:last_place] if s.action == "move"][-1]
    t_name = carry.args[2]  # from the last pick across the wall to the goal pose
    t: Traj = objects[t_name]
    low = min(q.y for q in t.waypoints)
    objects[t_name] = Traj((t.waypoints[0], Conf(t.waypoints[-1].x, low), t.waypoints[-1]))
    check = validate(w, p, dataclasses.replace(plan, objects=objects))  # type: ignore[arg-type]
    assert not check.valid and check.stage == "geometry"
    assert "collides" in check.message


def _simulate(world: Scene, steps: list[tuple[str, tuple[Any, ...]]]) -> str:
    """Run the geometric check on steps given with values; its message ("ok" when it passes)."""
    values: dict[str, Any] = {}
    named = []
    for action, args in steps:
        names = []
        for a in args:
            if isinstance(a, str):
                names.append(a)
            else:
                values[f"x{len(values)}"] = a
                names.append(f"x{len(values) - 1}")
        named.append((action, tuple(names)))
    try:
        check_geometry(world, None, None, named, values)  # type: ignore[arg-type]
    except Invalid as e:
        return str(e)
    return "ok"


def _pick_steps(world: Scene, robot: int, grasp: Grasp) -> list[tuple[str, tuple[Any, ...]]]:
    b, p = world.blocks[0], world.start[0]
    q = grasp_conf(p, grasp)
    home = world.homes[robot]
    (t,) = st.plan_motion(world, home, q) or ()
    r = world.robots[robot]
    return [("move", (r, home, t, q)), ("pick", (r, b.name, p, grasp, q))]


def test_a_grasp_off_the_top_face_fails_the_geometry() -> None:
    w = make_world("mirror", 1, 0)
    b = w.blocks[0]
    top = b.height / 2 + 0.15
    # a good grasp passes every step (only the goal, never reached here, fails at the end)
    assert _simulate(w, _pick_steps(w, 0, Grasp(0.0, top))).endswith("is not standing at the end")
    assert "top face" in _simulate(w, _pick_steps(w, 0, Grasp(0.0, top + 0.2)))
    assert "top face" in _simulate(w, _pick_steps(w, 0, Grasp(b.width / 2, top)))


def test_robots_collide_with_each_other() -> None:
    """Robot r1 descends to the conf where r0 holds the block: the domain allows it, the
    geometry does not."""
    w = make_world("mirror", 1, 0)
    g = Grasp(0.0, w.blocks[0].height / 2 + 0.15)
    first = _pick_steps(w, 0, g)
    q = first[0][1][3]
    (t,) = st.plan_motion(w, w.homes[1], q) or ()
    alone = [("move", ("r1", w.homes[1], t, q))]
    assert _simulate(w, alone).endswith("does not reach its goal")  # fine without r0 there
    steps = [*first, ("move", ("r1", w.homes[1], t, q))]
    assert "step 3" in _simulate(w, steps) and "collides" in _simulate(w, steps)
