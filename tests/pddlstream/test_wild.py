"""PDDLStream's ``WildOutput``: facts a stream reports beyond its certified ones are true from
then on; the planner uses them in later searches and the replay takes them on the stream's word.

The shapes are those of PDDLStream's examples, on tasks of this file: a stream that declines
what it certifies but reports a path of unit steps (``discrete_tamp/push``'s ``push-target``), a
stream that certifies nothing and only reports facts (``continuous_tamp/ffrob``'s
``connect``), and a generator of lists that wraps its outputs (``push-direction``)."""

from __future__ import annotations

import dataclasses

import pytest

from llmpas.errors import PlannerError
from llmpas.pddlstream import And, Exists, PDDLProblem, from_fn, from_list_fn, solve
from llmpas.pddlstream.solution_check import validate
from llmpas.pddlstream.solving import SolveContext
from llmpas.pddlstream.wrappers import WildOutput

DOMAIN = """
(define (domain line)
  (:requirements :strips)
  (:predicates (Point ?a) (Target ?a) (Step ?a ?b) (At ?a) (Conf ?a))
  (:action go :parameters (?a ?b)
    :precondition (and (Step ?a ?b) (At ?a))
    :effect (and (At ?b) (not (At ?a)))))
"""
JUMP = """
(define (stream line)
  (:stream jump :inputs (?a ?b) :domain (and (Point ?a) (Target ?b)) :certified (Step ?a ?b)))
"""
CONNECT = """
(define (stream line)
  (:stream connect :inputs (?a) :domain (Conf ?a)))
"""
FORWARD = """
(define (stream line)
  (:stream forward :inputs (?a) :domain (Point ?a) :outputs (?b)
    :certified (and (Point ?b) (Step ?a ?b))))
"""


def unit_steps(a: int, b: int) -> WildOutput:
    """The direct step is declined; the unit steps from ``a`` to ``b`` are reported."""
    return WildOutput(facts=[("Step", x, x + 1) for x in range(a, b)])


def attempts_of(problem: PDDLProblem, algorithm: str) -> tuple[list, list]:
    seen: list = []
    plan, _, _ = solve(
        problem, algorithm=algorithm, max_time=60, context=SolveContext(on_attempt=seen.append)
    )
    return plan, seen


@pytest.mark.parametrize("algorithm", ["adaptive", "incremental"])
def test_facts_reported_instead_of_the_certified_one_are_planned_with(algorithm) -> None:
    problem = PDDLProblem(
        DOMAIN,
        {},
        JUMP,
        {"jump": from_list_fn(unit_steps)},
        [("Point", 0), ("Target", 4), ("At", 0)],
        ("At", 4),
    )
    plan, (attempt,) = attempts_of(problem, algorithm)
    assert plan == [("go", (x, x + 1)) for x in range(4)]
    assert validate(attempt).valid
    assert ("step", 1, 2) in attempt.solution.certificate.all_facts


def test_a_stream_without_outputs_or_certified_facts_may_report_facts() -> None:
    def connect(a):  # as ffrob's connect: edges to configurations it makes up
        if a == 3:
            return WildOutput(facts=[("Target", a)])
        return WildOutput(facts=[("Step", a, a + 1), ("Conf", a + 1)])

    # stream outputs are not init objects here (see docs/pddlstream.md): the goal names none
    goal = Exists(["?x"], And(("At", "?x"), ("Target", "?x")))
    problem = PDDLProblem(
        DOMAIN, {}, CONNECT, {"connect": from_list_fn(connect)}, [("Conf", 0), ("At", 0)], goal
    )
    plan, (attempt,) = attempts_of(problem, "incremental")
    assert plan == [("go", (x, x + 1)) for x in range(3)]
    assert validate(attempt).valid


def test_a_generator_of_lists_may_wrap_its_outputs() -> None:
    def forward(a):
        yield WildOutput([(a + 1,)])

    goal = Exists(["?x"], And(("Step", 0, "?x"), ("At", "?x")))
    problem = PDDLProblem(
        DOMAIN, {}, FORWARD, {"forward": forward}, [("Point", 0), ("At", 0)], goal
    )
    plan, (attempt,) = attempts_of(problem, "adaptive")
    assert plan == [("go", (0, 1))]
    assert validate(attempt).valid


def test_the_replay_needs_the_reported_facts() -> None:
    problem = PDDLProblem(
        DOMAIN,
        {},
        JUMP,
        {"jump": from_list_fn(unit_steps)},
        [("Point", 0), ("Target", 2), ("At", 0)],
        ("At", 2),
    )
    _, (attempt,) = attempts_of(problem, "adaptive")
    plan = attempt.result.plan
    assert plan.reported
    without = dataclasses.replace(
        plan, reported=frozenset(), certified=plan.certified - plan.reported
    )
    result = dataclasses.replace(attempt.result, plan=without, improvements=())
    forged = dataclasses.replace(attempt, result=result)
    assert not validate(forged).valid


def test_a_wild_output_where_pddlstream_takes_none_is_refused_in_one_line() -> None:
    problem = PDDLProblem(
        DOMAIN,
        {},
        FORWARD,
        {"forward": from_fn(lambda a: WildOutput([(a + 1,)]))},
        [("Point", 0), ("At", 0)],
        Exists(["?x"], And(("Step", 0, "?x"), ("At", "?x"))),
    )
    with pytest.raises(PlannerError, match=r"from_fn function returned a WildOutput"):
        solve(problem, max_time=30)


def test_reported_facts_of_a_derived_predicate_are_refused() -> None:
    domain = DOMAIN.replace(
        "(:action go", "(:derived (Far ?a) (and (Point ?a) (Target ?a)))\n  (:action go"
    )
    problem = PDDLProblem(
        domain,
        {},
        JUMP,
        {"jump": from_list_fn(lambda a, b: WildOutput(facts=[("Far", a)]))},
        [("Point", 0), ("Target", 4), ("At", 0)],
        ("At", 4),
    )
    with pytest.raises(PlannerError, match=r"'far' cannot be given as a fact"):
        solve(problem, max_time=30)
