"""Continuous values from the command line: a problem file names objects in mixed case, the
bindings module gives their values, and the cost idioms of PDDLStream's files work."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from llmpas.cli import main
from llmpas.language.problem import read_problem
from llmpas.planning import PlannerConfig, PlanStatus, solve

from .data.slide2d import streams as slide2d

DATA = Path(__file__).parent / "data" / "slide2d"
FILES = [str(DATA / f) for f in ("domain.pddl", "problem.pddl")]


@pytest.mark.parametrize("algorithm", ["focused", "incremental"])
def test_values_named_in_the_file_reach_streams_and_equal_outputs_share_names(
    algorithm: str,
) -> None:
    slide2d.CALLS.clear()
    problem = read_problem(
        FILES[0], FILES[1], DATA / "stream.pddl", slide2d.STREAMS, values=slide2d.VALUES
    )
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    assert result.plan is not None
    assert ("bB", "Right") in slide2d.CALLS  # streams see names as written
    # pGoal's value reaches the plan as the object pgoal (a sampled pose equal to it keeps a name
    # of its own: stream outputs are not merged with init objects; equal outputs share one)
    goal_value = slide2d.VALUES["pGoal"]
    same = {
        n
        for n, v in result.plan.objects.items()
        if isinstance(v, np.ndarray) and np.array_equal(v, goal_value)
    }
    assert "pgoal" in same and len(same) <= 2
    assert result.plan.cost == pytest.approx(len(result.plan.steps))  # (= (Cost) 1)


def test_plan_from_the_command_line_with_values(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["plan", *FILES, "--streams", str(DATA / "stream.pddl")]
    code = main([*args, "--bindings", f"{DATA / 'streams.py'}:STREAMS", "--json"])
    out = capsys.readouterr().out
    assert code == 0, out
    data = json.loads(out)
    assert data["status"] == "solved"


def test_a_missing_cost_value_is_one_line_at_load(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (DATA / "problem.pddl").read_text().replace("(= (Cost) 1)", "")
    problem = tmp_path / "problem.pddl"
    problem.write_text(text)
    args = [FILES[0], str(problem), "--streams", str(DATA / "stream.pddl")]
    code = main(["plan", *args, "--bindings", f"{DATA / 'streams.py'}:STREAMS"])
    err = capsys.readouterr()
    assert code == 3  # an input error
    message = (err.err + err.out).strip()
    assert "no value of 'cost' is given" in message
    assert message.count("\n") == 0, message


def test_printed_plan_names_objects_as_the_file_writes_them(
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = ["plan", *FILES, "--streams", str(DATA / "stream.pddl")]
    assert main([*args, "--bindings", f"{DATA / 'streams.py'}:STREAMS"]) == 0
    out = capsys.readouterr().out
    assert "(slide bA pA0 pGoal)" in out
    assert "pgoal" not in out
