"""Same inputs, same run (issue #35, item 5): every task of the suite, run with the labelled
oracle by `llmpas run TASK.toml` in this process and by `bench prompting --jobs 2` in worker
processes of another interpreter with another hash seed, gives the same rounds (goals, plans,
outcomes, anomalies, answers, verdict).

Before: `llmpas run` could not read a suite task file at all (its ``[judge]`` table was an
unknown field) and a scenario without it was ended by the task goal, not by the task's intent.
The bench side runs once for the module (2 workers); each task is one test."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from llmpas.cli import main
from llmpas.experiments.suite import SUITE_DIR
from llmpas.experiments.suite.task_files import task_files
from tests.test_system import clean_blackboard  # noqa: F401 (autouse)

TASKS = sorted(Path(p).stem for p in task_files(SUITE_DIR))
SRC = Path(__file__).parents[2] / "src"


def signature(loop: dict[str, Any]) -> list[Any]:
    """What a run did, round by round, without its timings."""
    out: list[Any] = [loop["success"], loop["message"]]
    for r in loop["rounds"]:
        plan = r["plan"]["plan"]
        steps = [f"{s['action']} {' '.join(s['args'])}" for s in plan["steps"]] if plan else None
        anomaly = r["anomaly"]
        reasoning = r.get("reasoning") or {}
        out.append(
            [
                r["goal"],
                r["status"],
                steps,
                anomaly and [anomaly["constraint"], anomaly["reason"], anomaly["observations"]],
                reasoning.get("goals"),
                reasoning.get("errors"),
            ]
        )
    return out


@pytest.fixture(scope="module")
def bench_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    """`bench prompting` (the oracle row, 2 jobs) over the whole suite, every run kept, in
    another interpreter whose hash seed is not this one's."""
    out = tmp_path_factory.mktemp("bench")
    mine = os.environ.get("PYTHONHASHSEED", "")
    env = {**os.environ, "PYTHONHASHSEED": "1" if mine != "1" else "2"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SRC), env.get("PYTHONPATH", "")]))
    command = [sys.executable, "-m", "llmpas.cli", "bench", "prompting", "--llm", "oracle"]
    command += ["--methods", "none", "--no-replan", "--jobs", "2", "--keep-runs"]
    subprocess.run([*command, "--out", str(out)], env=env, check=True, capture_output=True)
    runs: dict[str, dict[str, Any]] = {}
    for path in (out / "runs").rglob("loop.json"):  # runs/<row>_<llm>_<task>_s0_<digest>
        task = next(t for t in TASKS if f"_{t}_s0_" in path.parent.name)
        runs[task] = json.loads(path.read_text())
    return runs


@pytest.mark.parametrize("task", TASKS)
def test_llmpas_run_and_bench_prompting_give_the_same_rounds(
    task: str, bench_runs: dict[str, dict[str, Any]], tmp_path: Path
) -> None:
    path = SUITE_DIR / f"{task}.toml"
    main(["run", str(path), "--llm", "oracle", "--out", str(tmp_path)])
    mine = json.loads((tmp_path / "loop.json").read_text())
    assert task in bench_runs
    assert signature(mine) == signature(bench_runs[task])
