"""The run records (:mod:`llmpas.system.records`): the fields ``loop.json`` always had, and the
robot's belief and the world's truth beside them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from llmpas.system import LoopResult, LoopStatus, loop_markdown, save_records

BEFORE = {"scenario", "success", "message", "status", "error", "llm_calls", "llm_time"}
BEFORE |= {"timings", "rounds"}


def test_loop_json_keeps_its_fields_and_adds_belief_and_truth(tmp_path: Path) -> None:
    result = LoopResult("s", False, (), "the task is done", believed=True, truth=False)
    save_records(result, tmp_path)
    saved = json.loads((tmp_path / "loop.json").read_text())
    assert set(saved) == BEFORE | {"believed", "truth", "verdict_basis"}
    assert saved["verdict_basis"] == "belief"  # not judged by a world here
    assert (saved["success"], saved["believed"], saved["truth"]) == (False, True, False)
    assert saved["status"] == "not-done"
    md = (tmp_path / "loop.md").read_text()
    assert "**not done**" in md and "Belief and truth: believed done, truly not done" in md


@pytest.mark.parametrize(
    ("success", "believed", "truth", "shown"),
    [
        (True, None, None, "believed done, no truth judged"),
        (False, None, None, "believed not done, no truth judged"),
        (True, True, True, "believed done, truly done"),
        (False, True, False, "believed done, truly not done"),
        (True, False, True, "believed not done, truly done"),
    ],
)
def test_belief_and_truth_side_by_side(
    success: bool, believed: bool | None, truth: bool | None, shown: str
) -> None:
    result = LoopResult("s", success, (), believed=believed, truth=truth)
    assert result.believed is (success if believed is None else believed)
    assert result.verdicts == shown
    assert result.status is (LoopStatus.DONE if success else LoopStatus.NOT_DONE)
    assert ("Belief and truth" in loop_markdown(result)) is (truth is not None)


def test_the_package_re_exports_every_name_of_the_module_it_replaced() -> None:
    import llmpas.system

    before = {
        "LLMFor",
        "LoopResult",
        "LoopSettings",
        "LoopStatus",
        "OnRound",
        "Round",
        "UNJUDGED",
        "close_loop",
        "counted",
        "execute",
        "loop_markdown",
        "plan",
        "run",
        "run_once",
        "save_loop",
        "save_once",
        "save_records",
    }
    assert before <= set(dir(llmpas.system))
    assert set(llmpas.system.__all__) <= set(dir(llmpas.system))


def test_a_perceived_verdict_says_so(tmp_path: Path) -> None:
    """A standard robot's run: judged on what it perceived, with no ground truth."""
    result = LoopResult("s", True, (), "the task is done", basis="perceived")
    assert result.verdicts == "believed done, perceived done" and result.truth is None
    save_records(result, tmp_path)
    saved = json.loads((tmp_path / "loop.json").read_text())
    assert saved["verdict_basis"] == "perceived" and saved["truth"] is None
    md = (tmp_path / "loop.md").read_text()
    assert "Verdict: believed done, perceived done (what the robot perceived" in md
    assert "Belief and truth" not in md
