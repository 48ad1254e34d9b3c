"""CSubBTs on an in-memory world: resampling, backtracking, anomaly reports, budgets."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import numpy as np
import py_trees
import pytest

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import SubAction, SubtreeSpec
from llmpas.execution.executor import ExecStatus, ExecutorConfig, execute
from llmpas.execution.robot_protocols import Perception, Robot, SkillResult
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom

from .toy import TABLE1, ToyWorld, pick_spec


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def run(world: ToyWorld, *specs: SubtreeSpec, max_ticks: int = 2000) -> Any:
    ctx = Context(world, world, Belief([], {}), np.random.default_rng(0))
    return execute(list(specs), ctx, ExecutorConfig(max_ticks=max_ticks))


def test_toy_world_implements_the_protocols() -> None:
    w = ToyWorld("t1a")
    assert isinstance(w, Robot) and isinstance(w, Perception)


def test_searches_other_regions_then_picks() -> None:
    world = ToyWorld("t1c")
    ep = run(world, pick_spec())
    assert ep.status is ExecStatus.SUCCESS
    assert world.held == "cube"
    assert [c for c in world.calls if c.startswith("look")] == ["look t1a", "look t1b", "look t1c"]
    assert ep.retries == 2 and ep.completed == (0, 1)


def test_slipped_grasp_is_retried_with_another_grasp() -> None:
    world = ToyWorld("t1a", slips=1)
    ep = run(world, pick_spec())
    assert ep.status is ExecStatus.SUCCESS
    assert [c for c in world.calls if c.startswith("grasp")] == [
        "grasp cube top",
        "grasp cube forward",
    ]


def test_object_elsewhere_ends_in_one_anomaly_naming_the_constraint() -> None:
    world = ToyWorld("t2")
    ep = run(world, pick_spec())
    assert ep.status is ExecStatus.ANOMALY and world.held is None
    report = ep.anomaly
    assert report.constraint == Atom("on", ("cube", "table1"))
    assert report.sub_action == "locate" and report.constraint_name == "Detected"
    # exhaustive: every region from every base pose
    looks = [c for c in world.calls if c.startswith("look")]
    assert len(looks) == 6 and set(looks) == {f"look {r}" for r in TABLE1}
    assert report.explored["base"] == ("'q1'", "'q2'")
    assert report.failures == {"Detected": 6}
    assert "(on cube table1)" in report.describe()
    json.dumps(report.to_json())  # JSON-serialisable


def test_sample_budget_bounds_exploration() -> None:
    world = ToyWorld("t2")
    regions = [f"r{i}" for i in range(100)]
    ep = run(
        world, pick_spec(regions=regions, bases=tuple(f"q{i}" for i in range(100)), max_samples=7)
    )
    assert ep.status is ExecStatus.ANOMALY
    assert sum(len(v) for v in ep.anomaly.explored.values()) <= 7


def test_tick_budget_stops_a_never_ending_skill() -> None:
    class Stuck(ToyWorld):
        def move_base(self, conf: Any) -> SkillResult:
            return SkillResult.failure("blocked")

    dims = (Dimension("base", lambda v: iter(int, 1), budget=10_000),)  # an endless sampler
    spec = SubtreeSpec(
        "move",
        (0,),
        "move",
        (),
        {},
        dims,
        (SubAction("move_base", lambda v, c: c.robot.move_base(v["base"]), needs=("base",)),),
        max_samples=10_000,
    )
    ep = run(Stuck("t1a"), spec, max_ticks=25)
    assert ep.status is ExecStatus.BUDGET and ep.ticks == 25
    assert "max_ticks=25" in ep.message


def test_stops_at_first_anomaly_and_later_subtrees_never_run() -> None:
    world = ToyWorld("t2")
    later = SubtreeSpec(
        "place",
        (2,),
        "place",
        ("cube",),
        {},
        (),
        (SubAction("release", lambda v, c: c.robot.release("cube", None)),),
    )
    ep = run(world, pick_spec(), later)
    assert ep.status is ExecStatus.ANOMALY
    assert ep.subtrees == ("move-and-pick cube", "place") and ep.completed == ()
    assert not any(e.node == "release" for e in ep.events)


def test_blackboard_is_released_after_a_run() -> None:
    run(ToyWorld("t1a"), pick_spec())
    assert not any(k.startswith("/csubbt") for k in py_trees.blackboard.Blackboard.storage)


def test_episode_json_round_trip(tmp_path: Any) -> None:
    ep = run(ToyWorld("t1b"), pick_spec())
    path = ep.save(tmp_path / "episode.json")
    data = json.loads(path.read_text())
    assert data["status"] == "success" and data["completed_steps"] == [0, 1]
    assert any(e["status"] == "backtrack" for e in data["timeline"])
