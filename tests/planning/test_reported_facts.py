"""Facts a stream reports beyond its certified ones (:class:`Facts`, PDDLStream's WildOutput)
are real facts from then on: later searches and stream instances use them, and the plan
records them. The task: a road is known only once a survey of a town reports it."""

from __future__ import annotations

import pytest

from llmpas.language import bindings
from llmpas.language.bindings import Facts
from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanStatus, solve

DOMAIN = """(define (domain roads)
  (:predicates (Town ?t) (Road ?a ?b) (At ?t) (Capital ?t))
  (:action drive :parameters (?a ?b)
    :precondition (and (Road ?a ?b) (At ?a))
    :effect (and (At ?b) (not (At ?a)))))
"""
STREAMS = """(define (stream roads)
  (:stream survey :inputs (?t) :domain (Town ?t)))
"""
ROADS = {"a": ["b"], "b": ["c"], "c": []}


def survey(t: str):
    yield Facts([("Road", t, n) for n in ROADS[t]] + [("Town", n) for n in ROADS[t]])


@pytest.mark.parametrize(
    ("algorithm", "p_success"), [("focused", 1.0), ("focused", 0.0), ("incremental", 1.0)]
)
def test_reported_facts_are_planned_with_and_recorded(algorithm, p_success) -> None:
    problem = Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=[("Town", "a"), ("At", "a"), ("Capital", "c")],
        goal="(exists (?t) (and (At ?t) (Capital ?t)))",
        implementations={"survey": bindings.sampler(survey, p_success=p_success)},
    )
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_iterations=20))
    if p_success and algorithm == "focused":  # a test certifying nothing: no plan needs it
        assert result.status is PlanStatus.UNSOLVABLE
        return
    assert result.status is PlanStatus.SOLVED, result.message
    assert [str(s) for s in result.plan.steps] == ["(drive a b)", "(drive b c)"]
    assert {str(a) for a in result.plan.reported} >= {"(road a b)", "(road b c)"}
