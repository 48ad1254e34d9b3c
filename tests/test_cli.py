"""The ``llmpas`` command line: plan on files, JSON output, and one-line errors for bad input."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from llmpas.cli import main

DATA = Path(__file__).parent / "planning" / "data"
FILES = [
    str(DATA / "domain.pddl"),
    str(DATA / "problem.pddl"),
    "--streams",
    str(DATA / "stream.pddl"),
    "--bindings",
    f"{DATA / 'streams.py'}:STREAMS",
]


def test_plan_files_with_bindings_prints_plan(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", *FILES]) == 0
    out = capsys.readouterr().out
    assert "solved" in out
    assert "(place b0" in out and "(place b1" in out
    assert "defers reach(" in out


def test_plan_json_is_machine_readable(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", *FILES, "--json", "--no-defer"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["status"] == "solved"
    assert data["stats"]["stream_calls"]["reach"] >= 4  # computed: reach evaluated while planning
    assert all(step["deferred"] == [] for step in data["plan"]["steps"])


def test_plan_quality_and_cost_in_the_output(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--example", "tamp2d", "--size", "2", "--quality", "anytime"]) == 0
    out = capsys.readouterr().out
    assert "quality anytime" in out and "plan cost" in out
    assert (
        main(["plan", "--example", "tamp2d", "--size", "2", "--json", "--quality", "optimal"]) == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert data["stats"]["quality"] == "optimal"
    assert data["improvements"][-1]["cost"] == data["plan"]["cost"] > 0
    assert main(["plan", "--example", "tamp2d", "--quality", "best"]) == 2  # a one-line error


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    return err


def test_missing_file_is_one_line_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "nope.pddl", str(DATA / "problem.pddl")]) == 3  # an input error
    line = _error_line(capsys)
    assert "nope.pddl: " in line and "no such file" in line


def test_malformed_domain_names_file_line_col(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "domain.pddl"
    bad.write_text("(define (domain d)\n  (:predicates (p ?x)\n  (:action a :parameters (?x)\n")
    assert main(["plan", str(bad), str(DATA / "problem.pddl")]) == 3
    line = _error_line(capsys)
    assert f"{bad}:3:3:" in line and "never closed" in line


def test_bindings_that_are_not_a_mapping(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", *FILES[:4], "--bindings", "json:JSONDecoder"]) == 3
    assert "not a mapping" in _error_line(capsys)


def test_declared_stream_without_implementation_is_named(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["plan", *FILES[:4], "--bindings", f"{DATA / 'streams.py'}:PARTIAL"]) == 3
    line = _error_line(capsys)
    assert "'reach'" in line and "no Python implementation" in line


def test_unknown_example_lists_known_ones(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--example", "nosuch"]) == 2
    line = _error_line(capsys)
    assert "nosuch" in line and "blocksworld" in line


def test_execute_prints_the_anomaly_and_writes_the_episode(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["execute", "object-loss-table", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "anomaly" in out and "(on cube table1_right)" in out
    assert {p.name for p in tmp_path.iterdir()} >= {
        "episode.json",
        "report.md",
        "report.html",
        "plan.xml",
    }


def test_execute_nominal_succeeds(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["execute", "nominal"]) == 0
    assert "success" in capsys.readouterr().out


def test_unknown_scenario_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["execute", "nosuch"]) == 2
    line = _error_line(capsys)
    assert "nosuch" in line and "object-loss-table" in line


def test_bt_export_writes_xml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bt", "export", "nominal", "--out", str(tmp_path)]) == 0
    xml = (tmp_path / "plan.xml").read_text()
    assert 'BTCPP_format="4"' in xml


def test_run_with_the_oracle_writes_the_loop_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "state-change-apple", "--llm", "oracle", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "task done" in out and "(cleaned apple)" in out
    assert (tmp_path / "loop.md").exists() and (tmp_path / "round-0" / "report.html").exists()


def test_run_with_a_missing_cassette_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "state-change-apple", "--llm", f"replay:{tmp_path}"]) == 5  # LLM
    line = _error_line(capsys)
    assert "no recorded response" in line and str(tmp_path) in line


def test_run_object_loss_is_the_pybullet_world_with_its_oracle(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "object-loss", "--llm", "oracle", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "task done" in out and "(scanned table4)" in out  # the table no camera saw
    assert (tmp_path / "round-0" / "report.html").exists() and (tmp_path / "episode.gif").exists()
    assert list((tmp_path / "snapshots").glob("*.png"))
    loop = (tmp_path / "loop.md").read_text()  # both prompts and answers, the goals taken
    assert "#### first-look: prompt" in loop and "#### goals: answer" in loop
    assert "(scanned table4)" in loop


def test_run_pybullet_options_and_unknown_scenarios_are_one_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["run", "state-change-apple", "--world", "pybullet", "--llm", "oracle"]) == 2
    assert "no scenario 'state-change-apple' in pybullet" in _error_line(capsys)
    assert main(["run", "state-change-apple", "--world", "mypkg.nosuch:WORLD"]) == 2
    assert "cannot import mypkg.nosuch" in _error_line(capsys)


def test_run_without_reasoning_works_in_every_world(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "state-change-apple", "--no-llm"]) == 1  # the anomaly, unresolved
    out = capsys.readouterr().out
    assert "round 0: goal (and (Cooled apple)) -> anomaly" in out and "not done" in out


def test_old_eager_flag_means_no_defer_and_warns(
    capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        assert main(["plan", *FILES, "--json", "--eager"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["stats"]["stream_calls"]["reach"] >= 1  # computed while planning
    assert all(step["deferred"] == [] for step in data["plan"]["steps"])
    assert "--eager is deprecated: say --no-defer" in caplog.text


def test_robot_command_is_the_worlds_own_with_one_parser(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``llmpas robot pybullet``: the ROS 2 world's registered command parses its options (the
    command line defines none of them); an unknown robot is one line naming the known ones."""
    from llmpas.system.catalog import robots
    from llmpas.worlds.pybullet_ros2 import robot_command

    assert robots()["pybullet"].command == "llmpas.worlds.pybullet_ros2.robot_command:run"
    with pytest.raises(SystemExit) as done:
        main(["robot", "pybullet", "--help"])
    assert done.value.code == 0
    shown = capsys.readouterr().out
    assert shown == robot_command.parser().format_help()  # the world's parser, the only one
    assert shown.count("--stall") >= 1 and "usage: llmpas robot pybullet" in shown
    assert main(["robot", "nao", "x"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'nao'" in err and "pybullet" in err
