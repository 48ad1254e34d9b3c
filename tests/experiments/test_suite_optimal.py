"""``l_gt`` checked against an independent optimal search, not against the oracle itself.

A suite file's ``l_gt`` is the resolution length of the oracle's run (its goals planned by the
default greedy search); the judge then finds the oracle's run has that length, which is true by
construction. Here the recovery is planned again, from the same anomaly state, with an OPTIMAL
classical search that counts actions (A* with an admissible heuristic, unit costs): no
resolution it finds may be shorter than ``l_gt``. A greedy detour recorded as ``l_gt``, a judge
that miscounts or a wrong number in a file fail this.

Stream-based planning is optimal only over the stream values it has at hand (optimistic ones for
``focused``, sampled ones for ``incremental``), so the optimal search can also come out longer;
it is never allowed to come out shorter.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import py_trees
import pytest

from llmpas.experiments.oracles.household import oracle
from llmpas.experiments.suite import SUITE_DIR, load_task, resolution_length
from llmpas.language.logic import Formula
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig
from llmpas.planning.config import Algorithm
from llmpas.system import LoopSettings, close_loop
from llmpas.worlds.api import RunOptions
from llmpas.worlds.household.decomposition import ExplorationConfig
from llmpas.worlds.household.plugin import HouseholdSession

# unit costs: the number of actions, not the drive distances the default search weighs
OPTIMAL = "astar(hmax(axioms=approximate_negative), cost_type=one)"
TASKS = (
    "ol02-table1",
    "ol06-drawer4",
    "ab04-microwave-cube",
    "sc02-apple-stove",
    "ab06-sink-mug",
    "sc06-apple-frozen-stove",
)


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


class OptimalSession:
    """The household session, planned with an optimal classical search after the first round
    (the first round, which runs into the anomaly, is planned as in the oracle's run, so that
    both resolutions start from the same anomaly state)."""

    def __init__(self, inner: HouseholdSession, algorithm: Algorithm) -> None:
        self.inner = inner
        self.optimal = replace(inner.planner, algorithm=algorithm, search=OPTIMAL)
        self.index = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    @property
    def planner(self) -> PlannerConfig:
        return self.inner.planner if self.index == 0 else self.optimal

    def problem(self, goal: Formula | str, index: int) -> Problem:
        self.index = index
        return self.inner.problem(goal, index)


def optimal_resolution(name: str, algorithm: Algorithm) -> int:
    task = load_task(SUITE_DIR / f"{name}.toml")
    inner = HouseholdSession.open(task.scenario, RunOptions(), ExplorationConfig())
    session = OptimalSession(inner, algorithm)
    result = close_loop(session, oracle(inner), LoopSettings())  # type: ignore[arg-type]
    assert result.success, result.message
    first = result.rounds[0].episode
    assert first is not None and first.anomaly is not None  # round 0 ran into the anomaly
    return resolution_length(result)


SHORTER_FOUND = pytest.mark.xfail(
    strict=True,
    reason="a finding, kept visible: from the same anomaly state the optimal search resolves "
    "sc02-apple-stove in 8 actions, the file's l_gt (the greedy oracle run) is 9",
)


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=SHORTER_FOUND) if n == "sc02-apple-stove" else n for n in TASKS],
)
def test_no_optimal_resolution_is_shorter_than_l_gt(name: str) -> None:
    task = load_task(SUITE_DIR / f"{name}.toml")
    assert optimal_resolution(name, "focused") >= task.l_gt


@pytest.mark.slow
@pytest.mark.parametrize("name", TASKS)
def test_no_optimal_resolution_over_sampled_values_is_shorter_than_l_gt(name: str) -> None:
    assert optimal_resolution(name, "incremental") >= load_task(SUITE_DIR / f"{name}.toml").l_gt
