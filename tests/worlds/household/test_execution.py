"""Household scenarios planned and executed without any LLM: nominal success, and one anomaly
report per unrecoverable anomaly type, naming the right constraint and what was explored."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import py_trees
import pytest

from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode, ExecStatus
from llmpas.language.logic import Atom, Not
from llmpas.planning import PlanResult
from llmpas.system import execute, plan
from llmpas.worlds.api import RunOptions
from llmpas.worlds.household.household_plugin import WORLD
from llmpas.worlds.household.sim import HouseholdWorld


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


@dataclass(frozen=True)
class Run:
    plan: PlanResult
    specs: tuple[SubtreeSpec, ...]
    episode: Episode
    world: HouseholdWorld  # the simulator, to check the truth


def run(name: str) -> Run:
    """Plan a household scenario once and execute it (the system's functions on its session)."""
    with WORLD.open(name, RunOptions()) as session:
        result, problem = plan(session, session.task, 0)
        assert result.solved, result.message
        specs, episode = execute(session, result, problem)
    assert episode is not None
    return Run(result, specs, episode, session.sim)


def test_nominal_scenario_succeeds_and_the_truth_agrees() -> None:
    r = run("nominal")
    assert r.episode.status is ExecStatus.SUCCESS  # type: ignore[union-attr]
    assert r.world.truth.inside.get("cube") == "bowl" or (
        r.world.truth.placements["cube"].region == "bowl"
    )
    # every plan step was covered by a completed subtree
    assert set(r.episode.completed) == set(range(len(r.plan.plan.steps)))  # type: ignore[union-attr]


@pytest.mark.parametrize("name", ["object-loss-table", "object-loss-drawer", "object-loss-basket"])
def test_object_loss_reports_the_object_is_not_where_it_was(name: str) -> None:
    r = run(name)
    ep = r.episode
    assert ep is not None and ep.status is ExecStatus.ANOMALY
    report = ep.anomaly
    assert report is not None
    assert report.constraint == Atom("on", ("cube", "table1_right"))
    assert report.constraint_name == "Detected" and report.sub_action == "locate"
    # it searched both regions of table1 from several base poses before giving up
    assert set(report.explored["view"]) == {"'table1_left'", "'table1_right'"}
    assert len(set(report.explored["view_base"])) >= 2
    assert report.failures["Detected"] >= 4
    # and it now knows it does not know where the cube is
    assert not [a for a in ep.belief if a.predicate == "atpose" and a.args[0] == "cube"]


@pytest.mark.parametrize(
    ("name", "blocked"),
    [("action-blocking-microwave", "microwave"), ("action-blocking-bowl", "bowl")],
)
def test_action_blocking_reports_the_full_receptacle(name: str, blocked: str) -> None:
    r = run(name)
    report = r.episode.anomaly  # type: ignore[union-attr]
    assert report is not None
    assert report.constraint == Not(Atom("full", (blocked,)))
    assert report.action == "move-and-place"
    # the robot saw what is really in there
    assert any(a.predicate == "supported" and a.args[2] == blocked for a in r.episode.belief)  # type: ignore[union-attr]


def test_state_change_reports_the_dirty_apple() -> None:
    r = run("state-change-apple")
    report = r.episode.anomaly  # type: ignore[union-attr]
    assert report is not None
    assert report.constraint == Not(Atom("dirty", ("apple",)))
    assert report.action == "cool"
    assert Atom("dirty", ("apple",)) in r.episode.belief  # type: ignore[union-attr]
    assert "dirty" in r.world.truth.properties["apple"]


def test_reports_render_for_prompts() -> None:
    report = run("object-loss-table").episode.anomaly  # type: ignore[union-attr]
    text = report.describe()  # type: ignore[union-attr]
    assert "(on cube table1_right)" in text and "table1_left" in text


def test_every_csubbt_of_a_household_plan_loads_in_behaviortree_cpp() -> None:
    pytest.importorskip("behaviortreepy")
    from llmpas.execution.export import load_in_btcpp, to_btcpp_files

    r = run("action-blocking-microwave")  # 12 steps: open, pick, place, close, heat ...
    files = to_btcpp_files(list(r.specs))
    assert len(files) == len(r.specs) + 1  # one per CSubBT plus the plan
    for text in files.values():
        load_in_btcpp(text)


def test_each_subtree_maps_back_to_its_plan_steps_and_atoms() -> None:
    r = run("nominal")
    steps = r.plan.plan.steps  # type: ignore[union-attr]
    covered = [i for spec in r.specs for i in spec.steps]
    assert covered == list(range(len(steps)))  # every step once, in order
    pick = next(s for s in r.specs if s.action == "move-and-pick")
    assert any(a.predicate == "atgrasp" and a.args[0] == "cube" for a in pick.atoms)
