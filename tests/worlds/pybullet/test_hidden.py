"""The PyBullet main job that needs its LLM: the cube is carried to a table no camera sees from
table1, among three it could be on. Replanning the task alone (no LLM) does not finish it; the
oracle (an upper bound) and the offline model's recorded answers (a cassette) do, and the web
page says which goals made the difference beside the replan-only run."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("ompl")

from llmpas.cli import main
from llmpas.experiments.worlds import ORACLE, LoopConfig, llm_for, run_loop
from llmpas.reasoning.backends.replay import ReplayBackend
from llmpas.worlds.api import RunOptions

QUIET = RunOptions(snapshots=False)
CASSETTES = Path(__file__).parents[2] / "data" / "cassettes" / "qwen1.5b-pybullet-hidden"


def _goals(result: object) -> list[str]:
    return [str(g) for r in result.rounds if r.proposal for g in r.proposal.goals]  # type: ignore[attr-defined]


def test_replanning_alone_does_not_find_the_hidden_cube() -> None:
    result = run_loop("object-loss", llm_for("replan", world="pybullet"), LoopConfig(options=QUIET))
    assert not result.success
    first = result.rounds[0]
    assert first.episode is not None and first.episode.anomaly is not None
    assert str(first.episode.anomaly.constraint) == "(on cube table1)"
    proposal = first.proposal
    assert proposal is not None and not proposal.ok  # the task restated cannot be planned
    assert "location unknown" in " ".join(proposal.parse.errors)
    # no camera saw the cube while the robot searched table1: every other table is open
    prompt = proposal.exchanges[-1].request.messages[1].content
    assert "places not searched yet for cube: table2, table3, table4" in prompt


def test_the_oracle_searches_the_right_table_and_finishes() -> None:
    result = run_loop("object-loss", ORACLE, LoopConfig(options=QUIET))
    assert result.success, result.message
    assert _goals(result) == ["(scanned table3)"]


def test_the_offline_models_recorded_answers_find_the_cube() -> None:
    """Qwen2.5-Coder-1.5B, recorded once with `llmpas run object-loss --record`: it searched
    table2 first (nothing), then table3 (the cube), and the task was done."""
    llm = ReplayBackend(CASSETTES, mode="replay")
    result = run_loop("object-loss", llm, LoopConfig(options=QUIET))
    assert result.success, result.message
    assert _goals(result) == ["(scanned table2)", "(scanned table3)"]
    assert all(r.proposal.first_look for r in result.rounds if r.proposal)


def test_in_the_papers_protocol_the_offline_model_does_not_finish() -> None:
    """The same model and first look with the loop's assists off (recorded with `llmpas run
    object-loss --protocol paper --record`): it restates the task, which is planned as given
    and cannot be while the cube is lost."""
    from llmpas.reasoning.assists import Assists

    llm = ReplayBackend(CASSETTES, mode="replay")
    result = run_loop("object-loss", llm, LoopConfig(options=QUIET, assists=Assists.none()))
    assert not result.success
    assert _goals(result) == ["(on cube bowl)"]
    assert len(result.rounds[0].proposal.exchanges) == 2  # type: ignore[union-attr]


@pytest.mark.slow
def test_the_page_names_the_decisive_goals_beside_the_replan_only_run(tmp_path: Path) -> None:
    out = tmp_path / "run"
    code = main(
        ["run", "object-loss", "--llm", f"replay:{CASSETTES}", "--out", str(out), "--with-replan"]
    )
    assert code == 0
    page = (out / "index.html").read_text()
    assert 'id="difference"' in page
    assert "Replanning alone (the task restated, no LLM) did not finish" in page
    assert "(scanned table3) were reached in round 3" in page
    assert 'href="replan-only/index.html"' in page
    assert (out / "replan-only" / "index.html").is_file()


def test_the_cli_replan_run_is_not_done(tmp_path: Path) -> None:
    assert main(["run", "object-loss", "--llm", "replan", "--out", str(tmp_path / "r")]) == 1
    assert main(["run", "object-loss", "--llm", "replan:x"]) != 0  # one line, no traceback


def test_in_the_two_table_variant_the_prompt_leaves_one_place() -> None:
    # the old main job: with two tables, the list of unsearched places gives the answer away
    result = run_loop(
        "object-loss-seen", llm_for("replan", world="pybullet"), LoopConfig(options=QUIET)
    )
    proposal = result.rounds[0].proposal
    assert proposal is not None
    prompt = proposal.exchanges[-1].request.messages[1].content
    assert "places not searched yet for cube: table2\n" in prompt + "\n"


def test_the_scenario_keeps_its_tables_apart() -> None:
    from llmpas.worlds.pybullet.run import scenarios

    scene = scenarios()["object-loss"].scene
    assert [t.name for t in scene.tables] == ["table1", "table2", "table3", "table4"]
    assert replace(scene).tables == scene.tables


METHODS_CASSETTES = CASSETTES.parent / "qwen1.5b-pybullet-methods"


@pytest.mark.parametrize(
    ("method", "votes", "goals"),
    [
        ("flp", 3, ["(scanned table3)"]),  # 3 checked answers: one named table3, the others
        # restated the task (rejected); one consultation instead of two
        pytest.param(
            "flp-multi", 1, ["(scanned table2)", "(scanned table3)"], marks=pytest.mark.slow
        ),
        pytest.param(
            "flp-hypotheses", 1, ["(scanned table2)", "(scanned table3)"], marks=pytest.mark.slow
        ),
    ],
)
def test_the_offline_models_answers_with_each_method_replay(
    method: str, votes: int, goals: list[str]
) -> None:
    """Recorded once with `llmpas run object-loss --method M [--votes K] --record`."""
    from llmpas.reasoning.methods import MethodConfig

    llm = ReplayBackend(METHODS_CASSETTES, mode="replay")
    config = LoopConfig(method=MethodConfig(method, votes=votes), options=QUIET)
    result = run_loop("object-loss", llm, config)
    assert result.success, result.message
    assert _goals(result) == goals
