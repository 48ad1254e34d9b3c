"""What any look saw is kept (issue #35, item 1): a failed detection forgets only the place it
failed at, so a sighting made elsewhere during the same search stays in the belief, and the
anomaly, the prompt's environment and the replan read it. Each scenario is the test's own (a
household file in tests/data/sight/, a PyBullet scenario built here); each test failed before
the change (the failed detection erased the sighting: "cube: location unknown")."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.replan import Replan
from llmpas.system import LoopResult
from llmpas.worlds.api import RunOptions
from llmpas.worlds.pybullet.pybullet_robot import Event
from llmpas.worlds.pybullet.pybullet_scenarios import scenarios
from tests.test_system import clean_blackboard  # noqa: F401 (autouse)

DATA = Path(__file__).parent / "data" / "sight"


class Restating(Replan):
    """The replan baseline (the task restated), keeping the requests it was sent."""

    def __init__(self, goal: str) -> None:
        super().__init__(goal)
        self.requests: list[Request] = []

    def complete(self, request: Request) -> Response:
        self.requests.append(request)
        return super().complete(request)


def first_anomaly(result: LoopResult) -> AnomalyReport:
    return next(r.episode.anomaly for r in result.rounds if r.episode and r.episode.anomaly)


def rests_on(report: AnomalyReport, obj: str) -> set[str]:
    """Where the anomaly's belief says ``obj`` rests (``supported`` facts' regions)."""
    return {
        str(a.args[2]) for a in report.belief if a.predicate == "supported" and a.args[0] == obj
    }


def prompts(llm: Restating) -> list[str]:
    return [m.content for r in llm.requests for m in r.messages]


def test_household_a_sighting_in_a_bowl_on_the_same_table_is_kept() -> None:
    """The cube is believed on table1_right; it lies in the bowl on table1_left. The pick's
    look along table1 sees it in the bowl (not on the table, so the detection fails): the
    belief keeps it in the bowl, the prompt says so, and replanning alone takes it from there."""
    llm = Restating("(and (On cube table2_left))")
    result = run_loop(str(DATA / "cube-dropped-in-bowl.toml"), llm)
    report = first_anomaly(result)
    assert any("cube in bowl" in o for o in report.observations)
    assert not any("not searched yet for cube" in p for p in prompts(llm))
    assert rests_on(report, "cube") == {"bowl"}
    assert "seen in bowl" in report.reason
    assert prompts(llm) and not any("cube: location unknown" in p for p in prompts(llm))
    assert any("- cube: on bowl" in p for p in prompts(llm))
    assert result.success, result.message


def test_pybullet_a_table_seen_from_another_base_pose_keeps_the_cube() -> None:
    """PyBullet (and the ROS 2 world, which runs the same session and subtrees): the cube is
    carried to the near corner of table3 while the robot drives to table1. From one of the
    pick's base poses facing table1, a camera sees it on table3: the belief keeps table3, the
    prompt does not call its place unknown, and the task restated is planned from there."""
    base = scenarios()["object-loss"]
    moved = replace(
        base,
        name="cube-slid-to-table3-corner",
        events=(Event("move_base", 1, "cube", "table3", 0.45, 0.25),),
        event_jitter=0.0,
    )
    llm = Restating(moved.goal)
    result = run_loop(moved, llm, LoopConfig(options=RunOptions(seed=1)), world="pybullet")
    report = first_anomaly(result)
    assert any("saw cube in table3" in o for o in report.observations)
    assert rests_on(report, "cube") == {"table3"}
    assert prompts(llm) and not any("cube: location unknown" in p for p in prompts(llm))
    assert any("- cube (green cube): on table3" in p for p in prompts(llm))
    assert not any("not searched yet for cube" in p for p in prompts(llm))
    assert result.success, result.message
