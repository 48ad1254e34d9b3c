"""Improving searches start near the incumbent: after a new incumbent, the next search
assumes stream instances only on real values (depth 1, ``Quality.improve_depth``), so that
placeholder detours, whose optimistic costs are lower bounds far below the real costs, are
tried only when the values already drawn allow nothing cheaper.

The task: a robot on a line visits points; a ``waypoint`` sampler offers new confs, and the
distance to a conf not sampled yet is optimistically 0.5 (a true lower bound: real moves cost
the distance plus one). Every detour through a waypoint looks cheaper than a direct move until
the waypoint is sampled; the cheapest plan uses no waypoint."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import pytest

from llmpas.language.bindings import cost, sampler, test
from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanResult, solve
from llmpas.planning import planner_run as run_module
from llmpas.planning.quality import QUALITIES

DOMAIN = """
(define (domain line)
  (:requirements :strips)
  (:predicates (Conf ?q) (AtConf ?q) (Motion ?q1 ?q2) (Visited ?q))
  (:functions (Dist ?q1 ?q2))
  (:action move
    :parameters (?q1 ?q2)
    :precondition (and (Motion ?q1 ?q2) (AtConf ?q1))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (Visited ?q2)
                 (increase (total-cost) (Dist ?q1 ?q2)))))
"""
STREAMS = """
(define (stream line)
  (:stream waypoint
    :inputs (?q)
    :domain (Conf ?q)
    :outputs (?w)
    :certified (Conf ?w))
  (:stream motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :certified (Motion ?q1 ?q2))
  (:function (Dist ?q1 ?q2) (and (Conf ?q1) (Conf ?q2))))
"""
POINTS = [0.0, 5.0, 1.0, 4.0, 2.0, 3.0]
OPTIMUM = 10.0  # 0 -> 1 -> 2 -> 3 -> 4 -> 5, five moves of cost 2


def waypoints(q: float) -> Iterator[tuple[float]]:
    k = 0
    while True:
        k += 1
        yield (q + 0.25 * k,)


def line_with_waypoints() -> Problem:
    init: list[tuple[Any, ...]] = [("Conf", p) for p in POINTS] + [("AtConf", POINTS[0])]
    return Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=init,
        goal=[("Visited", p) for p in POINTS[1:]],
        implementations={
            "waypoint": sampler(waypoints),
            "motion": test(lambda a, b: a != b),
            "dist": cost(lambda a, b: abs(a - b) + 1.0, opt_fn=lambda a, b: 0.5),
        },
    )


def plan(name: str, iterations: int) -> PlanResult:
    config = PlannerConfig(
        quality=name,  # type: ignore[arg-type]
        defer=False,
        max_time=120,
        search_time=120,
        max_iterations=iterations,
    )
    return solve(line_with_waypoints(), config)


def without_improve_depth(monkeypatch: pytest.MonkeyPatch) -> None:
    """The planner with every quality searching at full depth after a new incumbent (the
    behaviour before ``improve_depth``)."""
    plain = {k: dataclasses.replace(q, improve_depth=None) for k, q in QUALITIES.items()}
    monkeypatch.setattr(run_module, "QUALITIES", plain)


@pytest.mark.parametrize("name", ["anytime", "optimal"])
def test_the_cheapest_plan_over_real_values_comes_before_detours(name: str) -> None:
    result = plan(name, iterations=8)
    assert result.solved and result.plan is not None
    assert result.plan.cost == pytest.approx(OPTIMUM)
    values = result.plan.objects
    assert all(values[a] in POINTS for step in result.plan.steps for a in step.args)
    assert QUALITIES[name].improve_depth == 1


@pytest.mark.parametrize("name", ["anytime", "optimal"])
def test_without_it_the_detours_use_up_the_same_iterations(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    without_improve_depth(monkeypatch)
    result = plan(name, iterations=8)
    assert result.solved and result.plan is not None
    assert result.plan.cost > OPTIMUM + 1  # still paying for detours it tried


def test_optimal_needs_one_search_after_its_first_plan() -> None:
    """Its first plan (A* over placeholders) goes through waypoints; the next search, on the
    real values only, finds the optimum: the second incumbent, one iteration later, with no
    stream called in between but the motion tests of that plan."""
    result = plan("optimal", iterations=8)
    first, second = result.improvements[:2]
    assert first.cost > OPTIMUM
    assert second.cost == pytest.approx(OPTIMUM)
    assert second.iteration == first.iteration + 1
    calls = result.improvements[1].stream_calls - result.improvements[0].stream_calls
    assert 0 < calls <= len(POINTS) - 1  # one motion test per move, no waypoint drawn


def test_improvements_count_iterations_and_stream_calls() -> None:
    result = plan("anytime", iterations=8)
    its = [i.iteration for i in result.improvements]
    calls = [i.stream_calls for i in result.improvements]
    assert its == sorted(set(its)) and its[0] >= 1 and its[-1] <= result.stats.iterations
    assert calls == sorted(calls) and calls[-1] <= sum(result.stats.stream_calls.values())
    as_json = result.to_json()["improvements"]
    assert [i["iteration"] for i in as_json] == its
    assert [i["stream_calls"] for i in as_json] == calls


def test_improve_depth_is_checked_and_fast_has_none() -> None:
    assert QUALITIES["fast"].improve_depth is None
    with pytest.raises(ValueError, match="improve_depth"):
        dataclasses.replace(QUALITIES["anytime"], improve_depth=0)
