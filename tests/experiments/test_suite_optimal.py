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
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import py_trees
import pytest

from llmpas.experiments.suite import SUITE_DIR, load_task, resolution_length
from llmpas.language.logic import Formula
from llmpas.planning import PlanResult, solve
from llmpas.planning.config import Algorithm
from llmpas.planning.downward import DownwardConfig, FastDownward
from llmpas.system import LoopConfig, close_loop, oracle_factory
from llmpas.worlds.household.loop_adapter import HouseholdLoopWorld
from llmpas.worlds.household.problem import make_problem

# unit costs: the number of actions, not the drive distances the default search weighs
OPTIMAL = "astar(hmax(axioms=approximate_negative), cost_type=one)"
TASKS = ("ol02-table1", "ol06-drawer4", "ab04-microwave-cube", "sc02-apple-stove")


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


@dataclass(frozen=True)
class OptimalWorld(HouseholdLoopWorld):
    """The household world, planned with an optimal classical search after the first round
    (the first round, which runs into the anomaly, is planned as in the oracle's run, so that
    both resolutions start from the same anomaly state)."""

    algorithm: Algorithm = "focused"

    def plan(self, goal: Formula | str, index: int) -> tuple[PlanResult, Any]:
        if index == 0:
            return super().plan(goal, index)
        rng = np.random.default_rng([self.seed, index, 1])
        problem = make_problem(self.house, self.belief, goal, rng)
        limits = replace(self.config.planner, algorithm=self.algorithm)
        search = DownwardConfig(OPTIMAL, max_time=limits.search_time, memory_mb=limits.memory_mb)
        return solve(problem, limits, classical=FastDownward(search)), problem


def optimal_resolution(name: str, algorithm: Algorithm) -> int:
    task = load_task(SUITE_DIR / f"{name}.toml")
    config = LoopConfig()
    plain = OptimalWorld.open(task.scenario, config.run)
    world = replace(plain, algorithm=algorithm)
    result = close_loop(world, lambda report: oracle_factory(world.sim, report), config)
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
