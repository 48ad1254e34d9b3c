"""Test streams that return False never break planning, however the domain uses their predicate.

A failed test records ``rejected__P`` facts; they must reach Fast Downward only as declared
predicates, whether ``P`` occurs positively, negatively, both, or nowhere in the domain."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from llmpas.language.bindings import sampler, test
from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanStatus, solve

ALGORITHMS = ("focused", "skeletons", "incremental")

# a block moves to a sampled pose; ``Contain`` (a test) says which region that pose is in
PRECONDITIONS = {
    "positive": "(and (AtPose ?b ?p1) (Pose ?b ?p2) (Region ?r) (Contain ?b ?p2 ?r))",
    "both": "(and (AtPose ?b ?p1) (Pose ?b ?p2) (Region ?r) (Contain ?b ?p2 ?r)"
    " (not (Contain ?b ?p1 ?r)))",
    "unused": "(and (AtPose ?b ?p1) (Pose ?b ?p2) (Region ?r) (Sampled ?p2))",
}

DOMAIN = """
(define (domain slide)
  (:requirements :strips)
  (:predicates (Block ?b) (Region ?r) (Pose ?b ?p) (AtPose ?b ?p) (In ?b ?r))
  (:action slide
    :parameters (?b ?p1 ?p2 ?r)
    :precondition {pre}
    :effect (and (AtPose ?b ?p2) (not (AtPose ?b ?p1)) (In ?b ?r))))
"""

STREAMS = """
(define (stream slide)
  (:stream sample-pose :inputs (?b) :domain (Block ?b) :outputs (?p)
    :certified (and (Pose ?b ?p) (Sampled ?p)))
  (:stream contain :inputs (?b ?p ?r) :domain (and (Pose ?b ?p) (Region ?r))
    :certified (Contain ?b ?p ?r)))
"""

REGIONS = {"left": (0.0, 10.0), "right": (10.0, 20.0)}


def slide_problem(use: str) -> Problem:
    def sample_pose(b: str) -> Iterator[tuple[float]]:
        # the first poses all miss the goal region: the test must reject them first
        yield from ((x,) for x in (1.0, 2.0, 3.0, 15.0, 4.0))

    def contain(b: str, p: float, r: str) -> bool:
        lo, hi = REGIONS[r]
        return lo <= p < hi

    init: list[tuple[object, ...]] = [("Block", "b"), ("Pose", "b", 0.5), ("AtPose", "b", 0.5)]
    init.append(("Pose", "b", 1.5))  # a known pose: test instances exist before any sampling
    init += [("Region", r) for r in REGIONS]
    return Problem.create(
        parse_domain(DOMAIN.format(pre=PRECONDITIONS[use])),
        parse_streams(STREAMS),
        init=init,
        goal=[("In", "b", "right")],
        implementations={
            "sample-pose": sampler(sample_pose, max_outputs=5),
            "contain": test(contain),
        },
    )


@pytest.mark.parametrize("algorithm", ALGORITHMS)
@pytest.mark.parametrize("use", sorted(PRECONDITIONS))
def test_failed_tests_never_break_planning(algorithm: str, use: str) -> None:
    problem = slide_problem(use)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    assert result.plan is not None
    (step,) = result.plan.steps
    assert step.action == "slide"
    if use == "unused":  # the domain never mentions Contain: incremental still evaluates it
        assert algorithm != "incremental" or result.stats.stream_calls["contain"] >= 4
    else:
        # the only pose the test accepts in the goal region
        assert result.plan.objects[step.args[2]] == 15.0
        assert result.stats.stream_calls["contain"] >= 1


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_a_positive_test_that_always_fails_makes_the_problem_unsolvable(algorithm: str) -> None:
    problem = slide_problem("positive")
    problem = Problem.create(
        problem.domain,
        problem.streams,
        init=problem.init,
        goal=problem.goal,
        implementations={
            "sample-pose": sampler(lambda b: iter([(1.0,), (2.0,)]), max_outputs=2),
            "contain": test(lambda b, p, r: False),
        },
    )
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.UNSOLVABLE, result.message
