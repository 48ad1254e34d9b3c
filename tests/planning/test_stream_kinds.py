"""``:predicate`` and ``:rule`` declarations planned with PDDLStream's semantics.

A 1-D table: blocks sit at poses; moving a block needs a pose that collides with no block at its
pose now (an external predicate, used only negated, through a derived predicate), and a
configuration that reaches it (IK; a rule says that whatever IK certifies is a configuration)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from llmpas.language.bindings import sampler
from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, solve

ALGORITHMS = ("focused", "incremental")

DOMAIN = """
(define (domain table1d)
  (:requirements :strips :derived-predicates)
  (:predicates (Block ?b) (Pose ?p) (Conf ?q) (Kin ?q ?p) (AtPose ?b ?p) (Goal ?p)
               (Collide ?p1 ?p2) (Unsafe ?p) (Placed ?b) (Touching ?b1 ?b2) (Pushed ?b))
  (:derived (Unsafe ?p)
    (exists (?b2 ?p2) (and (AtPose ?b2 ?p2) (Collide ?p ?p2))))
  (:action move
    :parameters (?b ?p1 ?p2 ?q)
    :precondition (and (Block ?b) (AtPose ?b ?p1) (Goal ?p2) (Kin ?q ?p2) (Conf ?q)
                       (not (Unsafe ?p2)))
    :effect (and (AtPose ?b ?p2) (not (AtPose ?b ?p1)) (Placed ?b)))
  (:action push
    :parameters (?b1 ?p1 ?b2 ?p2)
    :precondition (and (AtPose ?b1 ?p1) (AtPose ?b2 ?p2) (Collide ?p1 ?p2))
    :effect (Pushed ?b2)))
"""

STREAMS = """
(define (stream table1d)
  (:rule :inputs (?q ?p) :domain (Kin ?q ?p) :certified (Conf ?q))
  (:stream ik :inputs (?p) :domain (Pose ?p) :outputs (?q) :certified (Kin ?q ?p))
  (:predicate (Collide ?p1 ?p2) (and (Pose ?p1) (Pose ?p2)))
)
"""


def collide(p1: float, p2: float) -> bool:
    return abs(p1 - p2) < 1.0


def table(
    goal: list[tuple[Any, ...]],
    calls: list[tuple[float, float]],
    extra: list[tuple[Any, ...]] | None = None,
    ik_fails: float | None = None,
) -> Problem:
    def counted(p1: float, p2: float) -> bool:
        calls.append((p1, p2))
        return collide(p1, p2)

    def ik(p: float) -> Iterator[tuple[float]]:
        if p != ik_fails:
            yield (p + 0.25,)

    init: list[tuple[Any, ...]] = []
    for b, x in (("a", 0.0), ("b", 5.0), ("c", 5.5)):
        init += [("Block", b), ("Pose", x), ("AtPose", b, x)]
    # goal poses: 5.2 collides with b, 9.0 is free
    init += [("Pose", 5.2), ("Goal", 5.2), ("Pose", 9.0), ("Goal", 9.0)] + (extra or [])
    return Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=init,
        goal=goal,
        implementations={"ik": sampler(ik), "Collide": counted},
    )


def replays(problem: Problem, result: PlanResult) -> None:
    assert result.plan is not None
    sem = Semantics(problem.domain, {o: "object" for o in result.plan.objects})
    steps = [(s.action, s.args) for s in result.plan.steps]
    r = replay(sem, set(problem.init) | result.plan.certified, steps, problem.goal)
    assert r.valid, r.message


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_used_negated_is_assumed_false_then_checked(algorithm: str) -> None:
    calls: list[tuple[float, float]] = []
    problem = table([("Placed", "a")], calls)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    assert result.plan is not None
    (step,) = result.plan.steps
    # the colliding goal pose was refused once the predicate was evaluated
    assert result.plan.objects[step.args[2]] == 9.0
    assert calls, "the external predicate was never evaluated"
    replays(problem, result)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_used_positively_holds_only_where_it_is_true(algorithm: str) -> None:
    calls: list[tuple[float, float]] = []
    problem = table([("Pushed", "c")], calls)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    assert result.plan is not None
    (step,) = result.plan.steps
    # b (at 5.0) and c itself (at 5.5) collide with c's pose; a (at 0.0) does not
    assert step.action == "push" and step.args[0] in ("b", "c") and step.args[2] == "c"
    assert calls  # positive uses need the predicate evaluated on real poses


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_that_is_never_true_makes_positive_uses_unsolvable(
    algorithm: str,
) -> None:
    problem = table([("Pushed", "c")], [])
    problem = Problem.create(
        problem.domain,
        problem.streams,
        init=problem.init,
        goal=problem.goal,
        implementations={"ik": lambda p: (p,), "collide": lambda p1, p2: False},
    )
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.UNSOLVABLE, result.message


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_rule_certifies_from_init_facts_and_stream_outputs(algorithm: str) -> None:
    # IK has no solution for 9.0, but init gives one: only the rule makes it a configuration
    problem = table([("Placed", "a")], [], [("Kin", 9.75, 9.0)], ik_fails=9.0)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    replays(problem, result)


def test_predicate_implementation_must_return_a_bool() -> None:
    problem = table([("Placed", "a")], [])
    problem = Problem.create(
        problem.domain,
        problem.streams,
        init=problem.init,
        goal=problem.goal,
        implementations={"ik": lambda p: (p,), "collide": lambda p1, p2: "yes"},
    )
    result = solve(problem, PlannerConfig(max_time=60))
    assert result.status is PlanStatus.ERROR
    assert "predicate 'collide' returned str, not bool" in result.message
