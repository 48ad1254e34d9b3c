"""The ``skeletons`` algorithm (focused planning with a skeleton queue, PDDLStream's adaptive): an
optimistic plan whose stream binding failed is kept and drawn again with more effort before the
task is searched again. ``focused`` (the default) keeps none: the counts before the queue."""

from __future__ import annotations

from llmpas.language.bindings import sampler, test
from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, solve
from llmpas.planning.downward import ClassicalPlan, ClassicalTask, FastDownward

DOMAIN = """
(define (domain shelf)
  (:requirements :strips)
  (:predicates (Item ?i) (Spot ?i ?s) (Stable ?i ?s) (On ?i ?s) (Placed ?i))
  (:action put :parameters (?i ?s)
    :precondition (and (Item ?i) (Spot ?i ?s) (Stable ?i ?s))
    :effect (and (On ?i ?s) (Placed ?i))))
"""
STREAMS = """
(define (stream shelf)
  (:stream sample-spot :inputs (?i) :domain (Item ?i) :outputs (?s) :certified (Spot ?i ?s))
  (:stream test-stable :inputs (?i ?s) :domain (Spot ?i ?s) :certified (Stable ?i ?s)))
"""


ALGORITHM = "skeletons"


class Counting(FastDownward):
    searches = 0

    def solve_task(
        self, domain_pddl: str, task: ClassicalTask, *, max_time: float | None = None
    ) -> ClassicalPlan:
        type(self).searches += 1
        return super().solve_task(domain_pddl, task, max_time=max_time)


def problem(bad: int) -> Problem:
    """Spots 0, 1, 2, ... for one item; only those >= ``bad`` are stable."""

    def spots(item: str):
        k = 0
        while True:
            yield (k,)
            k += 1

    return Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=[("Item", "box")],
        goal=[("Placed", "box")],
        implementations={
            "sample-spot": sampler(spots),
            "test-stable": test(lambda item, spot: spot >= bad),
        },
    )


def test_a_failed_binding_is_drawn_again_before_searching_again() -> None:
    """One unstable spot: the first binding fails on it; the kept skeleton draws the next spot
    in the next iteration, which holds: no second search (before the queue: 4 searches, the
    task searched again with the evaluated instances disabled, then with them re-enabled)."""
    Counting.searches = 0
    result = solve(
        problem(bad=1), PlannerConfig(algorithm=ALGORITHM, max_time=60), classical=Counting()
    )
    assert result.plan is not None
    assert [(s.action, s.args[0]) for s in result.plan.steps] == [("put", "box")]
    assert result.plan.objects[result.plan.steps[0].args[1]] == 1
    assert (Counting.searches, result.stats.iterations) == (1, 2)
    assert result.stats.stream_calls["sample-spot"] == 2


def test_the_queue_interleaves_draws_with_searches_and_drops_a_spent_skeleton() -> None:
    """Three unstable spots: the skeleton is drawn once per iteration, a search between draws,
    until the fourth spot holds (3 searches; before the queue: 10). Eight: its effort is spent
    after three draws, and new searches find the plan (20 searches; before: 30)."""
    for bad, searches in ((3, 3), (8, 20)):
        Counting.searches = 0
        result = solve(
            problem(bad=bad), PlannerConfig(algorithm=ALGORITHM, max_time=120), classical=Counting()
        )
        assert result.plan is not None
        assert result.plan.objects[result.plan.steps[0].args[1]] == bad
        assert Counting.searches == searches
        assert result.stats.stream_calls["sample-spot"] == bad + 1


def test_focused_keeps_no_skeleton() -> None:
    """The same problems with ``focused``: searched again after each failed binding."""
    for bad, searches in ((1, 4), (3, 10), (8, 30)):
        Counting.searches = 0
        config = PlannerConfig(algorithm="focused", max_time=120)
        result = solve(problem(bad=bad), config, classical=Counting())
        assert result.plan is not None
        assert Counting.searches == searches


FLUENT_STREAMS = """
(define (stream shelf)
  (:stream sample-spot :inputs (?i) :domain (Item ?i) :outputs (?s) :certified (Spot ?i ?s))
  (:stream test-stable :inputs (?i ?s) :domain (Spot ?i ?s) :fluents (Placed)
    :certified (Stable ?i ?s)))
"""


def test_a_plan_with_a_fluent_stream_is_drawn_again_too() -> None:
    """The same shelf with a fluent test (it sees the state of the step that uses it): the
    failed binding is kept and drawn again, its fluent test evaluated again in the new
    values' context, rather than searched again (before: a plan with a fluent instance was
    never kept, and each failed draw cost a search)."""
    seen: list[list[object]] = []

    def stable(item: str, spot: int, fluents: list[object]) -> bool:
        seen.append(list(fluents))
        return spot >= 3

    def spots(item: str):  # type: ignore[no-untyped-def]
        k = 0
        while True:
            yield (k,)
            k += 1

    prob = Problem.create(
        parse_domain(DOMAIN),
        parse_streams(FLUENT_STREAMS),
        init=[("Item", "box")],
        goal=[("Placed", "box")],
        implementations={"sample-spot": sampler(spots), "test-stable": test(stable)},
    )
    counts = {}
    for algorithm in (ALGORITHM, "focused"):
        Counting.searches = 0
        config = PlannerConfig(algorithm=algorithm, max_time=120, defer=False)
        result = solve(prob, config, classical=Counting())
        assert result.plan is not None, result.message
        assert result.plan.objects[result.plan.steps[0].args[1]] == 3
        counts[algorithm] = Counting.searches
    assert seen and all(f == [] for f in seen)  # nothing placed before the step: no fluents
    assert counts[ALGORITHM] < counts["focused"]
