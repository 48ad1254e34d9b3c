"""``eager`` streams (PDDLStream's ``StreamInfo(eager=True)``): called on every real binding
before each search, and still assumed on inputs not computed yet, unless ``p_success=0``."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from llmpas.language.bindings import StreamInfo, sampler
from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanStatus, solve

DOMAIN = """
(define (domain reach)
  (:predicates (Pose ?p) (Goal ?p) (Kin ?p ?q) (At ?p))
  (:action go :parameters (?p ?q) :precondition (and (Goal ?p) (Kin ?p ?q)) :effect (At ?p)))
"""

# the goal pose comes from a sampler with no inputs; IK is needed on it
STREAMS = """
(define (stream reach)
  (:stream goal-pose :outputs (?p) :certified (and (Pose ?p) (Goal ?p)))
  (:stream ik :inputs (?p) :domain (Pose ?p) :outputs (?q) :certified (Kin ?p ?q)))
"""


def reach(asked: list[float], **ik_info: object) -> Problem:
    def goal_pose() -> Iterator[tuple[float]]:
        yield (7.0,)

    def ik(p: float) -> Iterator[tuple[float]]:
        asked.append(p)
        yield (p / 2,)

    return Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=[("Pose", 1.0), ("Pose", 2.0)],
        goal="(exists (?p) (and (Goal ?p) (At ?p)))",
        implementations={"goal-pose": sampler(goal_pose), "ik": sampler(ik, **ik_info)},
    )


def test_an_eager_stream_is_called_on_real_inputs_and_still_assumed() -> None:
    asked: list[float] = []
    result = solve(reach(asked, eager=True), PlannerConfig(max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    # called on both real poses before the first search, and on the sampled goal pose, which
    # the plan reached through its optimistic instance
    assert asked[:2] == [1.0, 2.0] and 7.0 in asked
    assert result.plan is not None
    assert [s.action for s in result.plan.steps] == ["go"]


def test_p_success_zero_is_never_assumed_so_the_goal_pose_is_never_reached() -> None:
    asked: list[float] = []
    result = solve(reach(asked, eager=True, p_success=0.0), PlannerConfig(max_time=60))
    assert result.status is not PlanStatus.SOLVED
    assert 7.0 not in asked


def test_eager_and_deferred_contradict() -> None:
    with pytest.raises(ValueError, match="eager"):
        StreamInfo(eager=True, deferred=True)
