"""The stream-based planner on a small 1-D pick-and-place problem and on in-memory planners."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from llmpas.language.bindings import sampler, test
from llmpas.language.domain import read_domain
from llmpas.language.logic import Atom
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.language.streams import read_streams
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, solve
from llmpas.planning.downward import (
    ClassicalPlan,
    ClassicalStatus,
    ClassicalTask,
    FastDownward,
)
from llmpas.planning.result import Algorithm

DATA = Path(__file__).parent / "data"
ALGORITHMS: tuple[Algorithm, ...] = ("focused", "skeletons", "incremental")


def make_problem(
    regions: dict[str, tuple[float, float]],
    goal_region: str = "r2",
    n_blocks: int = 3,
    n_goal: int = 2,
    reach: Any = None,
    deferred_reach: bool = True,
    seed: int = 0,
    reach_sampler: Any = None,
) -> Problem:
    rng = np.random.default_rng(seed)

    def sample_pose(b: str, r: str) -> Iterator[tuple[float]]:
        lo, hi = regions[r]
        while hi - lo >= 1.0:  # a region narrower than a block has no pose
            yield (round(float(rng.uniform(lo, hi - 1.0)), 3),)

    def cfree(b1: str, p1: float, b2: str, p2: float) -> bool:
        return abs(p1 - p2) >= 1.0

    def default_reach(b: str, p: float) -> tuple[float]:
        return (p + 0.5,)

    init: list[tuple[Any, ...]] = [("HandEmpty",), ("Conf", 0.0), ("AtConf", 0.0)]
    init += [("Region", r) for r in regions]
    for i in range(n_blocks):
        init += [("Block", f"b{i}"), ("Pose", f"b{i}", float(i)), ("AtPose", f"b{i}", float(i))]
    return Problem.create(
        read_domain(DATA / "domain.pddl"),
        read_streams(DATA / "stream.pddl"),
        init=init,
        goal=[("In", f"b{i}", goal_region) for i in range(n_goal)],
        implementations={
            "sample-pose": sampler(sample_pose, max_outputs=6),
            "test-cfree": test(cfree),
            "reach": sampler(
                reach_sampler or (lambda b, p: iter([(reach or default_reach)(b, p)])),
                deferred=deferred_reach,
            ),
        },
    )


WIDE = {"r1": (0.0, 3.0), "r2": (5.0, 8.0)}


def replays(problem: Problem, result: PlanResult) -> bool:
    assert result.plan is not None
    sem = Semantics(problem.domain, {o: "object" for o in result.plan.objects})
    steps = [(s.action, s.args) for s in result.plan.steps]
    r = replay(sem, set(problem.init) | result.plan.certified, steps, problem.goal)
    assert r.valid, r.message
    return r.valid


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_solves_and_plan_replays_to_goal(algorithm: Algorithm) -> None:
    problem = make_problem(WIDE)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=30))
    assert result.status is PlanStatus.SOLVED, result.message
    assert replays(problem, result)
    # two blocks must be picked and placed; moves come on top
    assert sum(s.action == "place" for s in result.plan.steps) >= 2  # type: ignore[union-attr]


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_exhausted_samplers_make_the_problem_unsolvable(algorithm: Algorithm) -> None:
    # r2 is narrower than a block: its sampler has no output, so no block can get there
    problem = make_problem({"r1": (0.0, 3.0), "r2": (5.0, 5.5)}, deferred_reach=True)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.UNSOLVABLE, result.message
    assert result.plan is None
    assert result.stats.stream_calls["sample-pose"] > 0
    assert "exhausted" in result.message


def test_deferred_streams_are_not_called_and_are_listed_per_step() -> None:
    problem = make_problem(WIDE)
    result = solve(problem, PlannerConfig(defer=True))
    assert result.plan is not None
    assert "reach" not in result.stats.stream_calls
    deferred = [d for s in result.plan.steps for d in s.deferred]
    assert deferred and all(d.stream == "reach" for d in deferred)
    assert set(result.plan.deferred) == set(deferred)
    for step in result.plan.steps:
        for d in step.deferred:
            # each pick/place names the configuration its deferred reach instance will produce
            assert step.action in ("move", "pick", "place")
            assert result.plan.objects[d.outputs[0]] is None
    assert replays(problem, result)


def test_eager_evaluates_the_deferrable_streams() -> None:
    problem = make_problem(WIDE)
    result = solve(problem, PlannerConfig(defer=False))
    assert result.plan is not None
    assert result.stats.stream_calls["reach"] >= 4
    assert result.plan.deferred == ()
    assert all(v is not None for v in result.plan.objects.values())
    assert replays(problem, result)


def test_collision_test_rejections_shape_the_plan() -> None:
    # every sampled pose in r2 is checked against blocks already there
    problem = make_problem({"r1": (0.0, 3.0), "r2": (5.0, 11.0)}, n_blocks=3, n_goal=3)
    result = solve(problem, PlannerConfig(max_time=60))
    assert result.plan is not None
    poses = [result.plan.objects[s.args[1]] for s in result.plan.steps if s.action == "place"]
    final = poses[-3:]
    assert all(abs(a - b) >= 1.0 for i, a in enumerate(final) for b in final[i + 1 :])
    assert replays(problem, result)


def test_stream_exception_is_an_error_naming_the_instance() -> None:
    def broken(b: str, p: float) -> tuple[float]:
        raise ZeroDivisionError("no reach")

    result = solve(make_problem(WIDE, reach=broken, deferred_reach=False))
    assert result.status is PlanStatus.ERROR
    assert "stream reach(" in result.message and "ZeroDivisionError" in result.message


def test_slow_streams_end_in_timeout() -> None:
    def slow(b: str, p: float) -> tuple[float]:
        time.sleep(0.2)
        return (p + 0.5,)

    result = solve(
        make_problem(WIDE, reach=slow, deferred_reach=False), PlannerConfig(max_time=0.5)
    )
    assert result.status is PlanStatus.TIMEOUT


def test_a_sampler_yielding_only_none_ends_at_the_deadline() -> None:
    def idle(b: str, p: float) -> Iterator[None]:
        while True:  # "nothing this time", forever
            yield None

    problem = make_problem(WIDE, deferred_reach=False, reach_sampler=idle)
    result = solve(problem, PlannerConfig(max_time=1.0))
    assert result.status is PlanStatus.TIMEOUT
    assert result.stats.stream_calls["reach"] >= 1


def test_an_exceeded_max_time_returns_without_searching() -> None:
    planner = ScriptedPlanner([])
    result = solve(make_problem(WIDE), PlannerConfig(max_time=1e-9), classical=planner)
    assert result.status is PlanStatus.TIMEOUT
    assert planner.calls == []


class ScriptedPlanner:
    """An in-memory classical planner that answers from a script (for the failure paths)."""

    def __init__(self, answers: list[ClassicalPlan]) -> None:
        self.answers = answers
        self.calls: list[tuple[str, str]] = []

    def solve(
        self, domain_pddl: str, problem_pddl: str, *, max_time: float | None = None
    ) -> ClassicalPlan:
        self.calls.append((domain_pddl, problem_pddl))
        return self.answers.pop(0)


@pytest.mark.parametrize(
    ("status", "expected"),
    [
        (ClassicalStatus.TIMEOUT, PlanStatus.TIMEOUT),
        (ClassicalStatus.CRASHED, PlanStatus.CRASHED),
        (ClassicalStatus.OUT_OF_MEMORY, PlanStatus.ERROR),
        (ClassicalStatus.ERROR, PlanStatus.ERROR),
    ],
)
def test_classical_failures_become_typed_results(
    status: ClassicalStatus, expected: PlanStatus
) -> None:
    planner = ScriptedPlanner([ClassicalPlan(status, (), None, 0.0, 0.0, "boom")])
    result = solve(make_problem(WIDE), classical=planner)
    assert result.status is expected
    assert "boom" in result.message
    assert len(planner.calls) == 1


def test_classical_task_assumes_optimistic_facts_with_placeholders() -> None:
    planner = ScriptedPlanner([ClassicalPlan(ClassicalStatus.ERROR, (), None, 0.0, 0.0, "x")])
    solve(make_problem(WIDE), PlannerConfig(lazy_tests=True), classical=planner)
    domain, problem = planner.calls[0]
    assert "stream__" not in domain  # no stream actions: optimistic facts are assumed
    assert "(contained b0 #o" in problem and "(reach b0 v0 #o" in problem
    assert "rejected__cfree" in domain  # the negated collision test is rewritten
    # #44: the negated test is evaluated for a plan's bindings only, not before the search
    assert "(cfree " not in problem


def test_negated_tests_on_every_binding_without_lazy_tests() -> None:
    planner = ScriptedPlanner([ClassicalPlan(ClassicalStatus.ERROR, (), None, 0.0, 0.0, "x")])
    solve(make_problem(WIDE), PlannerConfig(), classical=planner)  # the default: eager
    _, problem = planner.calls[0]
    assert "(cfree b0 v0 b1 v1)" in problem  # real bindings of the negative test: evaluated


def _placeholders(problem_pddl: str) -> set[str]:
    return set(re.findall(r"#o\d+", problem_pddl))


def test_placeholders_are_shared_per_stream_output_and_level() -> None:
    # 5 blocks x 2 regions: 10 sample-pose instances, and reach / cfree instances on their
    # outputs; evaluated streams share one placeholder per (stream, output, level)
    planner = ScriptedPlanner([ClassicalPlan(ClassicalStatus.ERROR, (), None, 0.0, 0.0, "x")])
    problem = make_problem(WIDE, n_blocks=5, deferred_reach=False)
    solve(problem, PlannerConfig(max_level=2, share_placeholders=True), classical=planner)
    shared = _placeholders(planner.calls[0][1])
    # sample-pose at level 1; reach at levels 1 (real poses) and 2 (placeholder poses)
    assert len(shared) == 3
    assert "(pose b0 #o1)" in planner.calls[0][1] and "(pose b4 #o1)" in planner.calls[0][1]


def test_deferred_placeholders_stay_one_per_instance() -> None:
    planner = ScriptedPlanner([ClassicalPlan(ClassicalStatus.ERROR, (), None, 0.0, 0.0, "x")])
    problem = make_problem(WIDE, n_blocks=5, deferred_reach=True)
    solve(problem, PlannerConfig(max_level=2, share_placeholders=True), classical=planner)
    reach = re.findall(r"\(reach (\S+) (\S+) (#o\d+)\)", planner.calls[0][1])
    assert len(reach) > 5
    assert len({q for _, _, q in reach}) == len(reach)  # one output per reach instance


def test_consumers_of_a_shared_placeholder_get_their_own_producers_value() -> None:
    regions = {"r1": (0.0, 3.0), "r2": (5.0, 11.0)}
    problem = make_problem(regions, n_blocks=3, n_goal=3, deferred_reach=False)
    result = solve(problem, PlannerConfig(max_time=60, share_placeholders=True))
    assert result.plan is not None
    facts = set(problem.init) | result.plan.certified
    reach = [a for a in facts if a.predicate == "reach"]
    assert len(reach) >= 3
    for a in reach:  # reach(b, p) was called on a pose sampled for b itself
        block, pose, _ = a.args
        assert Atom("pose", (block, pose)) in facts
    assert replays(problem, result)


def test_a_plan_whose_streams_all_succeed_is_kept_without_searching_again() -> None:
    class Counting(FastDownward):
        calls = 0

        def solve_task(
            self, domain_pddl: str, task: ClassicalTask, *, max_time: float | None = None
        ) -> ClassicalPlan:
            Counting.calls += 1
            return super().solve_task(domain_pddl, task, max_time=max_time)

    problem = make_problem(WIDE, n_blocks=1, n_goal=1, deferred_reach=False)
    result = solve(problem, PlannerConfig(max_time=60), classical=Counting())
    assert result.plan is not None
    # the last iteration found the evaluated plan valid with the real values: no search (one
    # block: its binding holds at once; with two, a failed binding is drawn again from the
    # skeleton queue, and a search may then find a plan over real values directly)
    assert result.stats.iterations >= 2
    assert Counting.calls == result.stats.iterations - 1
    assert all(not a.startswith("#") for s in result.plan.steps for a in s.args)
    assert replays(problem, result)


def test_evaluates_only_what_the_plan_relies_on() -> None:
    # block 2 stays where it is: no pose is ever sampled for it
    result = solve(make_problem(WIDE, n_blocks=3, n_goal=1))
    assert result.plan is not None
    sampled = {p for p in result.plan.objects if p.startswith("s")}
    assert len(sampled) == result.stats.stream_calls["sample-pose"]
    assert result.stats.stream_calls["sample-pose"] <= 2


def test_plan_result_json_round_trip() -> None:
    result = solve(make_problem(WIDE))
    data = result.to_json()
    assert data["status"] == "solved"
    assert len(data["plan"]["steps"]) == len(result.plan.steps)  # type: ignore[union-attr]
    assert data["stats"]["stream_calls"] == dict(result.stats.stream_calls)


def test_the_cheaper_of_two_supporting_instances_is_evaluated() -> None:
    """Two streams certify the same fact; the plan needs one: the lower overhead/p_success
    is the one evaluated."""
    from llmpas.language.domain import parse_domain
    from llmpas.language.streams import parse_streams

    domain = parse_domain("""(define (domain d) (:predicates (Item ?x) (Ok ?x) (Done ?x))
      (:action finish :parameters (?x) :precondition (Ok ?x) :effect (Done ?x)))""")
    streams = parse_streams("""(define (stream s)
      (:stream slow :inputs (?x) :domain (Item ?x) :certified (Ok ?x))
      (:stream fast :inputs (?x) :domain (Item ?x) :certified (Ok ?x)))""")
    for cheap, dear in (("fast", "slow"), ("slow", "fast")):
        problem = Problem.create(
            domain,
            streams,
            init=[("Item", "a")],
            goal=[("Done", "a")],
            implementations={
                cheap: test(lambda x: True, overhead=1.0),
                dear: test(lambda x: True, overhead=5.0, p_success=0.5),
            },
        )
        result = solve(problem)
        assert result.solved
        assert dict(result.stats.stream_calls) == {cheap: 1}
