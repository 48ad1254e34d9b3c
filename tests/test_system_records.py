"""Records are never lost: the loop's record after every round, on LLM errors, crashes and
interrupts, an overall deadline, and reports that hostile answers cannot break."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest

from llmpas.errors import RobotLostError
from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.reasoning.llm import LLMError, Request, Response
from llmpas.system import LoopResult, LoopStatus, loop_markdown, save_records

SCENARIO = "object-loss-table"  # the task fails once (the cube is lost), then the LLM is asked


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


class Failing:
    """Answers ``answers`` in turn, then raises ``error``."""

    name = "failing"

    def __init__(self, error: BaseException, *answers: str) -> None:
        self.error = error
        self.answers = list(answers)

    def complete(self, request: Request) -> Response:
        if not self.answers:
            raise self.error
        return Response(self.answers.pop(0), model="failing")


class Saver:
    """An ``on_round`` that writes the records to a folder and keeps each one's status."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.statuses: list[str] = []

    def __call__(self, result: LoopResult) -> None:
        save_records(result, self.folder)
        self.statuses.append(json.loads((self.folder / "loop.json").read_text())["status"])


def test_records_are_written_after_every_round_and_at_the_end(tmp_path: Path) -> None:
    saver = Saver(tmp_path)
    llm = Failing(LLMError("unused"), *["Goals: (and (scanned table2_right))"] * 20)
    result = run_loop(SCENARIO, llm, LoopConfig(), on_round=saver)
    assert result.status in (LoopStatus.DONE, LoopStatus.NOT_DONE)
    # one record per plan-and-execute step and per LLM answer, then the final one
    steps = len(result.rounds) + sum(r.proposal is not None for r in result.rounds)
    assert saver.statuses == ["running"] * steps + [result.status.value]
    saved = json.loads((tmp_path / "loop.json").read_text())
    assert len(saved["rounds"]) == len(result.rounds)
    assert saved["success"] is result.success  # the existing fields are kept


@pytest.mark.parametrize(
    ("error", "status"),
    [
        (LLMError("openai:m at 127.0.0.1:9: HTTP 500 (3 attempts)"), "llm-error"),
        (KeyboardInterrupt(), "interrupted"),
        (RuntimeError("a bug"), "crashed"),
        (RobotLostError("/navigate_to_pose vanished; ROS_DOMAIN_ID=7"), "robot-lost"),
    ],
)
def test_an_error_keeps_the_rounds_already_run(
    tmp_path: Path, error: BaseException, status: str
) -> None:
    saver = Saver(tmp_path)
    with pytest.raises(type(error)):
        run_loop(SCENARIO, Failing(error), LoopConfig(), on_round=saver)
    saved = json.loads((tmp_path / "loop.json").read_text())
    assert saved["status"] == status
    assert saved["error"]
    assert saved["success"] is False
    assert len(saved["rounds"]) == 1  # the first round ran: its plan and its anomaly are kept
    assert saved["rounds"][0]["episode"]["anomaly"] is not None
    md = (tmp_path / "loop.md").read_text()
    assert f"not done ({status})" in md and "## Round 0" in md


def test_the_deadline_stops_the_loop_cleanly_between_steps(tmp_path: Path) -> None:
    from llmpas.system import close_loop
    from llmpas.worlds.household.household_decomposition import ExplorationConfig
    from llmpas.worlds.household.household_plugin import HouseholdSession, scenario_path
    from llmpas.worlds.household.scenario import load_scenario

    ticks = iter(range(0, 10_000, 10))  # a clock that advances 10 s at every look
    config = LoopConfig(deadline=25.0)
    world = HouseholdSession.open(
        load_scenario(scenario_path(SCENARIO)), config.options, ExplorationConfig()
    )
    llm = Failing(LLMError("unused"), *["Goals: (and (scanned table2_right))"] * 9)
    saver = Saver(tmp_path)
    result = close_loop(world, llm, config, saver, clock=lambda: float(next(ticks)))
    assert result.status is LoopStatus.DEADLINE and not result.success
    assert "deadline" in result.message
    assert 1 <= len(result.rounds) < 2 * config.max_rounds + 1
    assert saver.statuses[-1] == "deadline"


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_a_bad_deadline_is_refused(bad: float) -> None:
    with pytest.raises(ValueError, match="deadline"):
        LoopConfig(deadline=bad)


HOSTILE = (
    "Sure!\n```\n</pre><script>alert(1)</script>\n````\nrm -rf / \x1b[2J\x1b]0;pwned\x07"
    " \ud800 \u2028 (and (on cube bowl))"
)


def test_a_hostile_answer_cannot_break_out_of_its_fence(tmp_path: Path) -> None:
    llm = Failing(LLMError("unused"), *[HOSTILE] * 50)
    result = run_loop(SCENARIO, llm, LoopConfig())
    assert any(r.proposal and r.proposal.exchanges for r in result.rounds)
    md = loop_markdown(result)
    md.encode("utf-8")  # no lone surrogate left
    assert "\x1b" not in md and "\x07" not in md and "\u2028" not in md
    assert "\\x1b[2J" in md and "\\ud800" in md  # escaped, still readable
    assert re.search(r"^`{5,}text$", md, flags=re.M)  # longer than the answer's 4 backticks
    # with every fenced block taken out (a block ends at the fence that opened it), nothing
    # of the answer is left: it never got out of its block
    outside = re.sub(r"^(`{3,})text\n.*?^\1$", "", md, flags=re.M | re.S)
    assert "<script>" not in outside and "rm -rf" not in outside and "```" not in outside
    save_records(result, tmp_path)  # writing it cannot fail either
    assert json.loads((tmp_path / "loop.json").read_text())["rounds"]
