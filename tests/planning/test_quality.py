"""Plan quality: the registry of searches, and fast / anytime / optimal on tasks whose cheapest
plan is known (a robot on a line visits points; moves are allowed within a reach, cost the
distance plus one; the optimum is computed here by a search over (position, visited) states)."""

from __future__ import annotations

import heapq
import itertools
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from llmpas.language.bindings import cost, test
from llmpas.language.domain import parse_domain
from llmpas.language.logic import FuncTerm
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, solve
from llmpas.planning.downward import DownwardConfig
from llmpas.planning.quality import QUALITIES, SEARCHES, Quality, SearchConfig, quality

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
  (:stream motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :certified (Motion ?q1 ?q2))
  (:function (Dist ?q1 ?q2) (and (Conf ?q1) (Conf ?q2))))
"""


def dist(a: float, b: float) -> float:
    return abs(a - b) + 1.0


def line_problem(points: list[float], reach: float) -> Problem:
    """Start at points[0]; visit every other point."""
    init: list[tuple[Any, ...]] = [("Conf", p) for p in points] + [("AtConf", points[0])]
    return Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=init,
        goal=[("Visited", p) for p in points[1:]],
        implementations={
            "motion": test(lambda a, b: a != b and abs(a - b) <= reach),
            "dist": cost(dist),
        },
    )


def optimum(points: list[float], reach: float) -> float | None:
    """The cheapest cost to visit every point from points[0] (uniform-cost search)."""
    goal = frozenset(range(1, len(points)))
    frontier: list[tuple[float, int, frozenset[int]]] = [(0.0, 0, frozenset())]
    best: dict[tuple[int, frozenset[int]], float] = {}
    while frontier:
        g, at, seen = heapq.heappop(frontier)
        if seen >= goal:
            return g
        if best.get((at, seen), float("inf")) < g:
            continue
        for nxt, p in enumerate(points):
            if nxt != at and p != points[at] and abs(p - points[at]) <= reach:
                key = (nxt, seen | {nxt})
                cost_ = g + dist(points[at], p)
                if cost_ < best.get(key, float("inf")):
                    best[key] = cost_
                    heapq.heappush(frontier, (cost_, *key))
    return None


def replayed_cost(problem: Problem, result: PlanResult, plan: Any) -> float:
    """The plan replayed from the init with the true distances; fails if it does not reach the
    goal."""
    names = dict(problem.objects)
    steps = [(s.action, s.args) for s in plan.steps]
    costs = {FuncTerm("dist", (a, b)): dist(names[a], names[b]) for _, (a, b) in steps}
    facts = set(problem.init) | set(plan.certified)
    sem = Semantics(problem.domain, dict.fromkeys(names, "object"), costs)
    out = replay(sem, facts, steps, problem.goal)
    assert out.valid, out.message
    return out.cost


def plan(problem: Problem, name: str, **kw: Any) -> PlanResult:
    return solve(problem, PlannerConfig(quality=name, max_time=60, search_time=60, **kw))  # type: ignore[arg-type]


# ------------------------------------------------------------------------------- registry


def test_every_registered_search_is_a_valid_fast_downward_configuration() -> None:
    for search in SEARCHES.values():
        for bound in (None, 0, 1234):
            command = search.command(bound)
            DownwardConfig(search=command)  # checks the axioms option and refuses max_time
            assert command.startswith(f"{search.engine}(")
            assert ("bound=" in command) == (bound is not None)
    assert SEARCHES["astar-hmax"].admissible and not SEARCHES["lazy-greedy-ff"].admissible


def test_each_quality_names_registered_searches_and_bad_names_are_refused() -> None:
    assert set(QUALITIES) == {"fast", "anytime", "optimal"}
    assert not QUALITIES["fast"].improve
    assert SEARCHES[QUALITIES["optimal"].first].admissible
    anytime = QUALITIES["anytime"]
    assert anytime.search(0).name == "lazy-greedy-ff"
    assert [anytime.search(k).name for k in (1, 2, 5, 9)] == [
        "wastar5-ff", "wastar3-ff", "astar-hmax", "astar-hmax",
    ]  # fmt: skip
    with pytest.raises(ValueError, match="unknown search"):
        Quality("x", "no-such-search", (), "")
    with pytest.raises(ValueError, match="choose one of"):
        quality("best")
    with pytest.raises(ValueError, match="quality must be one of"):
        PlannerConfig(quality="best")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="patience"):
        PlannerConfig(patience=0)
    with pytest.raises(ValueError, match="bound"):
        SearchConfig("x", "astar", ("blind()", "bound=3"), True, "")
    with pytest.raises(ValueError, match="bound"):
        SEARCHES["astar-blind"].command(-1)


# ------------------------------------------------------------------------------- behaviour


POINTS = [0.0, 5.0, 1.0, 4.0, 2.0, 3.0]  # greedy zig-zags; the optimum sweeps 1..5


def test_optimal_finds_the_known_optimum_and_fast_does_not_here() -> None:
    problem = line_problem(POINTS, reach=10.0)
    best = optimum(POINTS, 10.0)
    fast, optimal = plan(problem, "fast"), plan(problem, "optimal")
    assert fast.solved and optimal.solved
    assert optimal.plan is not None and fast.plan is not None
    assert optimal.plan.cost == pytest.approx(best)
    assert replayed_cost(problem, optimal, optimal.plan) == pytest.approx(best)
    assert fast.plan.cost > optimal.plan.cost  # greedy zig-zags
    assert optimal.stats.quality == "optimal" and fast.stats.quality == "fast"
    assert len(fast.improvements) == 1 and fast.improvements[0].plan is fast.plan


def test_anytime_improvements_get_cheaper_and_each_replays() -> None:
    problem = line_problem(POINTS, reach=10.0)
    result = plan(problem, "anytime")
    assert result.solved and result.plan is not None
    costs = [i.cost for i in result.improvements]
    assert len(costs) >= 2, "the first (greedy) plan here is not the cheapest"
    assert costs == sorted(costs, reverse=True) and len(set(costs)) == len(costs)
    assert [i.cpu for i in result.improvements] == sorted(i.cpu for i in result.improvements)
    for imp in result.improvements:
        assert replayed_cost(problem, result, imp.plan) == pytest.approx(imp.cost)
    assert result.plan is result.improvements[-1].plan
    assert result.plan.cost == pytest.approx(optimum(POINTS, 10.0))
    as_json = result.to_json()
    assert [i["cost"] for i in as_json["improvements"]] == costs
    assert as_json["stats"]["quality"] == "anytime"


def test_an_unsolvable_task_stays_unsolvable_in_every_quality() -> None:
    problem = line_problem([0.0, 1.0, 9.0], reach=2.0)
    for name in QUALITIES:
        result = plan(problem, name)
        assert result.status is PlanStatus.UNSOLVABLE, name
        assert not result.improvements


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(st.integers(0, 12), min_size=3, max_size=5, unique=True),
    st.sampled_from([3.0, 5.0, 20.0]),
)
def test_optimal_is_never_costlier_than_fast_and_matches_the_optimum(
    points: list[int], reach: float
) -> None:
    values = [float(p) for p in points]
    best = optimum(values, reach)
    problem = line_problem(values, reach)
    fast, optimal = plan(problem, "fast"), plan(problem, "optimal")
    if best is None:
        assert not fast.solved and not optimal.solved
        return
    assert fast.plan is not None and optimal.plan is not None
    assert optimal.plan.cost <= fast.plan.cost + 1e-9
    assert optimal.plan.cost == pytest.approx(best)
    assert replayed_cost(problem, optimal, optimal.plan) == pytest.approx(best)


def test_a_limit_while_improving_keeps_the_cheapest_plan() -> None:
    problem = line_problem(POINTS, reach=10.0)
    result = plan(problem, "anytime", max_stream_calls=8, max_empty_samples=5)
    assert result.solved and result.plan is not None
    assert "kept; stopped: stream-call limit reached" in result.message
    assert result.plan.cost > optimum(POINTS, 10.0)  # type: ignore[operator]
    assert result.plan is result.improvements[-1].plan
    for a, b in itertools.pairwise(result.improvements):
        assert b.cost < a.cost
