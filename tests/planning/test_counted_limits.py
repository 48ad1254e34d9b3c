"""Counted planner limits: the verdict is a function of the problem and the config, not of the
machine's speed; a counted limit is reported as ``limit`` and a time limit (a safety net) as
``timeout``, never as ``unsolvable``."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from llmpas.language.bindings import sampler, test
from llmpas.language.domain import read_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import read_streams
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, solve
from llmpas.planning import instances as instances_module
from llmpas.planning import planner_run as run_module
from llmpas.planning import tamp as tamp_module
from llmpas.planning.downward import DownwardConfig, _invariant_arguments
from llmpas.planning.result import Algorithm

DATA = Path(__file__).parent / "data"
WIDE = {"r1": (0.0, 3.0), "r2": (5.0, 8.0)}
NARROW = {"r1": (0.0, 3.0), "r2": (5.0, 5.5)}  # r2 is narrower than a block: no pose there
FF = "ff(axioms=approximate_negative)"


def place_problem(
    regions: dict[str, tuple[float, float]] = WIDE,
    *,
    empty_before_each: int = 0,
    sleep: float = 0.0,
    reach_only_none: bool = False,
) -> Problem:
    """Three blocks, two to put in r2. The pose sampler yields ``empty_before_each`` ``None``
    ("nothing this time") before each pose, sleeping ``sleep`` seconds before each ``None``."""
    rng = np.random.default_rng(0)

    def sample_pose(b: str, r: str) -> Iterator[tuple[float] | None]:
        lo, hi = regions[r]
        while hi - lo >= 1.0:
            for _ in range(empty_before_each):
                time.sleep(sleep)
                yield None
            yield (round(float(rng.uniform(lo, hi - 1.0)), 3),)

    def reach(b: str, p: float) -> Iterator[tuple[float] | None]:
        while reach_only_none:
            yield None
        yield (p + 0.5,)

    init: list[tuple[Any, ...]] = [("HandEmpty",), ("Conf", 0.0), ("AtConf", 0.0)]
    init += [("Region", r) for r in regions]
    for i in range(3):
        init += [("Block", f"b{i}"), ("Pose", f"b{i}", float(i)), ("AtPose", f"b{i}", float(i))]
    return Problem.create(
        read_domain(DATA / "domain.pddl"),
        read_streams(DATA / "stream.pddl"),
        init=init,
        goal=[("In", f"b{i}", "r2") for i in range(2)],
        implementations={
            "sample-pose": sampler(sample_pose, max_outputs=6),
            "test-cfree": test(lambda b1, p1, b2, p2: abs(p1 - p2) >= 1.0),
            "reach": sampler(reach, deferred=False),
        },
    )


def verdict(result: PlanResult) -> dict[str, Any]:
    """Everything about a result that must not depend on the machine's speed."""
    plan = result.plan
    return {
        "status": result.status,
        "message": result.message,
        "steps": [str(s) for s in plan.steps] if plan else None,
        "objects": {k: repr(v) for k, v in plan.objects.items()} if plan else None,
        "iterations": result.stats.iterations,
        "stream_calls": dict(result.stats.stream_calls),
    }


class SlowClock:
    """A ``time`` module whose ``perf_counter`` advances ``step`` seconds at every reading: the
    planner seems to run on a machine far slower than this one."""

    def __init__(self, step: float) -> None:
        self.step = step
        self.now = 0.0

    def perf_counter(self) -> float:
        self.now += self.step
        return self.now


def slowed(monkeypatch: pytest.MonkeyPatch, step: float) -> None:
    clock = SlowClock(step)
    monkeypatch.setattr(tamp_module, "time", clock)
    monkeypatch.setattr(instances_module, "time", clock)
    monkeypatch.setattr(run_module, "time", clock)


# ------------------------------------------------------------------------------------ config


def test_the_validation_preset_counts_and_keeps_time_limits_as_safety_nets() -> None:
    config = PlannerConfig.validation()
    assert config.deterministic and not PlannerConfig().deterministic
    assert config.max_stream_calls is not None and config.max_empty_samples is not None
    assert math.isfinite(config.max_time) and math.isfinite(config.search_time)
    assert config.max_time >= 60.0  # a safety net, not the household's former 60 s verdict
    tuned = PlannerConfig.validation(defer=False, seed=3)
    assert (tuned.defer, tuned.seed, tuned.max_stream_calls) == (False, 3, config.max_stream_calls)


@pytest.mark.parametrize(
    "bad",
    [
        {"max_stream_calls": 0},
        {"max_empty_samples": -1},
        {"max_empty_samples": True},
        {"max_time": math.inf},
        {"search_time": math.nan},
    ],
)
def test_bad_limits_are_refused(bad: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        PlannerConfig(**bad)


def test_the_translators_invariant_time_cut_never_comes_before_its_cpu_limit() -> None:
    for budget in (0.3, 1.0, 29.5, 300.0):
        option, seconds = _invariant_arguments(budget)
        assert option == "--invariant-generation-max-time"
        assert int(seconds) > math.ceil(budget) + 1  # the child's soft CPU limit


# ------------------------------------------------------------------------------ speed


@pytest.mark.parametrize("algorithm", ["focused", "incremental"])
def test_the_verdict_does_not_change_when_the_clock_runs_slow(
    monkeypatch: pytest.MonkeyPatch, algorithm: Algorithm
) -> None:
    config = PlannerConfig.validation(algorithm=algorithm, max_time=1e7, max_empty_samples=2)
    problems = {
        "solvable": lambda: place_problem(WIDE, empty_before_each=3),
        "unsolvable": lambda: place_problem(NARROW, empty_before_each=3),
    }
    fast = {name: verdict(solve(make(), config)) for name, make in problems.items()}
    assert fast["solvable"]["status"] is PlanStatus.SOLVED
    assert fast["unsolvable"]["status"] is PlanStatus.UNSOLVABLE
    # every reading of the planner's clock now takes 10 s: a run of hours, within the net
    slowed(monkeypatch, 10.0)
    slow = {name: verdict(solve(make(), config)) for name, make in problems.items()}
    assert slow == fast
    # the household's former limits (max_time 60 s as the verdict) do not survive this clock
    former = solve(problems["solvable"](), PlannerConfig(algorithm=algorithm, max_time=60.0))
    assert former.status is PlanStatus.TIMEOUT


def test_the_verdict_does_not_change_when_the_samplers_are_slow() -> None:
    config = PlannerConfig.validation(max_empty_samples=2)
    fast = verdict(solve(place_problem(empty_before_each=3), config))
    slow = verdict(solve(place_problem(empty_before_each=3, sleep=0.01), config))
    assert fast["status"] is PlanStatus.SOLVED
    assert slow == fast


@pytest.mark.parametrize("algorithm", ["focused", "incremental"])
def test_a_sampler_yielding_only_none_is_counted_not_timed(algorithm: Algorithm) -> None:
    # without max_empty_samples it runs until max_time (tests/planning/test_tamp.py); with it,
    # each call gives up after 3, the instance stays usable, and planning stops at the
    # iteration limit (not unsolvable: the sampler may yield a value on a later call)
    config = PlannerConfig.validation(
        algorithm=algorithm, max_empty_samples=3, max_iterations=4, max_time=30.0
    )

    def idle() -> Problem:  # both samplers
        return place_problem(reach_only_none=True, empty_before_each=10**6)

    result = solve(idle(), config)
    assert result.status is PlanStatus.LIMIT, result.message
    assert "max_iterations=4" in result.message
    assert verdict(solve(idle(), config)) == verdict(result)


# ------------------------------------------------------------------------------- limits


@pytest.mark.parametrize("algorithm", ["focused", "incremental"])
def test_the_iteration_limit_is_a_limit_not_unsolvable(algorithm: Algorithm) -> None:
    config = PlannerConfig.validation(algorithm=algorithm)
    full = solve(place_problem(), config)
    assert full.status is PlanStatus.SOLVED and full.stats.iterations >= 2
    cut = solve(place_problem(), PlannerConfig.validation(algorithm=algorithm, max_iterations=1))
    assert cut.status is PlanStatus.LIMIT and cut.plan is None
    assert "iteration limit" in cut.message and "max_iterations=1" in cut.message


def test_the_stream_call_limit_is_a_limit_naming_it() -> None:
    full = solve(place_problem(), PlannerConfig.validation())
    calls = sum(full.stats.stream_calls.values())
    assert full.status is PlanStatus.SOLVED and calls > 2
    cut = solve(place_problem(), PlannerConfig.validation(max_stream_calls=2))
    assert cut.status is PlanStatus.LIMIT, cut.message
    assert "max_stream_calls=2" in cut.message
    assert sum(cut.stats.stream_calls.values()) == 2
    exact = solve(place_problem(), PlannerConfig.validation(max_stream_calls=calls))
    assert verdict(exact) == verdict(full)  # the limit is not reached when exactly enough


def test_the_time_safety_net_is_a_timeout_not_unsolvable(monkeypatch: pytest.MonkeyPatch) -> None:
    # an unsolvable problem on a clock so slow that max_time passes first
    slowed(monkeypatch, 10.0)
    result = solve(place_problem(NARROW), PlannerConfig.validation(max_time=100.0))
    assert result.status is PlanStatus.TIMEOUT, result.message
    assert "max_time=100" in result.message


def test_a_search_engines_own_time_limit_is_refused() -> None:
    # its expiry ends the search like an exhausted space (exit code 12): it would read as
    # unsolvable, depending on the machine's speed
    with pytest.raises(ValueError, match="max_time"):
        DownwardConfig(search=f"lazy_greedy([{FF}],max_time=5)")
    DownwardConfig(search=f"lazy_greedy([{FF}],bound=20)")  # a cost bound is a count
