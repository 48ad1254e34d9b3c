"""Fluent streams (``:fluents``) through ``llmpas.pddlstream``: a stream gets the fluent facts of
the state where its output is used, the plan replays with each such fact checked in its own
state, and what stays unsupported is refused in one line."""

from __future__ import annotations

import dataclasses

import pytest

from llmpas.cli import main
from llmpas.pddlstream import PDDLProblem, from_fn, from_test, solve
from llmpas.pddlstream.solution_check import validate
from llmpas.pddlstream.translate import Unsupported

from .test_runner import SCRIPTS

DOMAIN = """
(define (domain d)
  (:requirements :strips)
  (:predicates (Obj ?o) (Ready ?o ?v) (Good ?v) (Done ?o) (Free))
  (:action finish :parameters (?o ?v)
    :precondition (and (Obj ?o) (Ready ?o ?v))
    :effect (Done ?o)))
"""


def test_the_motion_stream_gets_the_fluents_of_the_state_it_is_used_in(load_script) -> None:
    loaded = load_script("motion_fluents")
    s = loaded.module
    plan, _, _ = s.solve(s.make_problem(), max_time=60)
    assert plan is not None
    (attempt,) = loaded.attempts
    v = validate(attempt)
    assert v.valid, v.message
    # replay the plan on the values: every motion it uses was planned with the poses of the
    # blocks on the table *then* (the held block is not among them)
    poses = {b: p for b, p in s.START.items()}
    made = {id(out[0]): facts for _q1, _q2, facts, out in s.CALLS if out is not None}
    moves = 0
    for a in plan:
        if a.name == "move":
            moves += 1
            q1, t, q2 = a.args
            facts = made[id(t)]
            assert sorted((b, tuple(p)) for _n, b, p in facts) == sorted(
                (b, tuple(p)) for b, p in poses.items()
            )
            assert s.free(q1, q2, list(poses.values()))
        elif a.name == "pick":
            del poses[a.args[0]]
        elif a.name == "place":
            poses[a.args[0]] = a.args[1]
    assert moves >= 2 and poses["B"][1] == s.SHELF
    # with the initial poses as fluents, no motion could carry B down to the shelf
    below = [s.ik("B", p)[0] for (p,) in s.pose_gen("B", s.REGIONS["shelf"])]
    above_b = s.ik("B", s.START["B"])[0]
    assert not any(s.free(above_b, q, list(s.START.values())) for q in below)


def test_the_replay_rejects_a_fluent_fact_used_outside_its_context(load_script) -> None:
    loaded = load_script("motion_fluents")
    s = loaded.module
    s.solve(s.make_problem(), max_time=60)
    (attempt,) = loaded.attempts
    plan = attempt.result.plan
    assert plan is not None and plan.fluent_facts
    # the motions' facts said to hold only where no block stands on the table
    moved = dataclasses.replace(
        plan, fluent_facts={a: frozenset({frozenset()}) for a in plan.fluent_facts}
    )
    tampered = dataclasses.replace(
        attempt, result=dataclasses.replace(attempt.result, plan=moved, improvements=())
    )
    v = validate(tampered)
    assert not v.valid and "precondition of (move" in v.message


def test_a_fluent_test_blocked_in_one_state_is_planned_in_another() -> None:
    """``ready`` fails while ``Free`` holds; ``finish`` cannot remove it, so the planner must
    find that ``Ready`` holds once another action made the state different: here, none can,
    and the answer is no plan; with an action that deletes ``Free`` it plans through it."""
    seen: list[list[tuple]] = []

    def ready(o, fluents=()):
        seen.append(list(fluents))
        return None if ("free",) in [tuple(f) for f in fluents] else ((o, 1),)

    streams = """
    (define (stream d)
      (:stream ready :inputs (?o) :domain (Obj ?o) :fluents (Free)
        :outputs (?v) :certified (Ready ?o ?v)))
    """
    stuck = PDDLProblem(
        DOMAIN, {}, streams, {"ready": from_fn(ready)}, [("Obj", "x"), ("Free",)], ("Done", "x")
    )
    plan, _, _ = solve(stuck, max_time=30)
    assert plan is None and seen and all(f == [("free",)] for f in seen)
    domain = DOMAIN.replace(
        "(:action finish",
        "(:action occupy :parameters () :precondition (Free) :effect (not (Free)))\n"
        "  (:action finish",
    )
    seen.clear()
    pds = PDDLProblem(
        domain, {}, streams, {"ready": from_fn(ready)}, [("Obj", "x"), ("Free",)], ("Done", "x")
    )
    plan, _, _ = solve(pds, max_time=30)
    assert plan is not None
    assert [a.name for a in plan] == ["occupy", "finish"] and plan[1].args == ("x", ("x", 1))
    assert [] in seen  # called in the state after occupy, where Free no longer holds


def test_unsupported_fluent_constructs_are_refused_in_one_line() -> None:
    streams = """
    (define (stream d)
      (:stream ready :inputs (?o) :domain (Obj ?o) :fluents (Free)
        :outputs (?v) :certified (Ready ?o ?v))
      (:stream good :inputs (?o ?v) :domain (Ready ?o ?v) :certified (Good ?v)))
    """
    impl = {"ready": from_fn(lambda o, fluents=(): (o,)), "good": from_test(lambda o, v: True)}
    pds = PDDLProblem(DOMAIN, {}, streams, impl, [("Obj", "x"), ("Free",)], ("Done", "x"))
    with pytest.raises(
        Unsupported,
        match=r"'ready': ':fluents', and its certified \(ready \.\.\.\) is in the :domain of "
        r"'good'",
    ) as e:
        solve(pds, max_time=30)
    assert "\n" not in str(e.value)
    only = streams.split("(:stream good")[0] + ")"
    pds = PDDLProblem(DOMAIN, {}, only, impl, [("Obj", "x"), ("Free",)], ("Done", "x"))
    with pytest.raises(
        Unsupported, match=r"':fluents' needs the focused algorithm .* not 'incremental'"
    ):
        solve(pds, algorithm="incremental", max_time=30)


def test_the_runner_plans_and_validates_the_fluent_script(capsys) -> None:
    assert main(["pddlstream", str(SCRIPTS / "motion_fluents.py")]) == 0
    out = capsys.readouterr().out
    assert "Solved: True" in out and "replay: valid" in out
