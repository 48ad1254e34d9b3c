"""The published offline-model figures replay exactly: Qwen2.5-Coder-1.5B's answers on the tasks
that measure the LLM were recorded once (``bench prompting --llm llama-cpp --record``, cassettes
in ``tests/data/cassettes/qwen1.5b-suite``); replaying them through the same command must give the
same goals and verdicts as ``docs/results/prompting-qwen1.5b-measures-llm_samples.csv``. Planner
verdicts are counted, not timed, so load cannot change which question the loop asks."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from llmpas.cli import main

ROOT = Path(__file__).parents[2]
CASSETTES = ROOT / "tests" / "data" / "cassettes" / "qwen1.5b-suite"
PUBLISHED = ROOT / "docs" / "results" / "prompting-qwen1.5b-measures-llm_samples.csv"
FIELDS = ("success", "verdict", "goals", "first_goals", "first_effective", "resolution_length")


def _rows(path: Path, methods: tuple[str, ...], tasks: tuple[str, ...]) -> dict[tuple, dict]:
    with path.open(newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["method"] in methods and r["task"] in tasks]
    return {(r["task"], r["method"]): {k: r[k] for k in FIELDS} for r in rows}


def _replay(method: str, tasks: tuple[str, ...], out: Path, *extra: str) -> Path:
    """Replays the recorded answers of ``method`` on ``tasks``; the samples CSV written."""
    argv = ["bench", "prompting", "--llm", f"replay:{CASSETTES}", "--methods", method]
    argv += ["--no-oracle", "--no-replan", "--samples", "1", *extra, "--out", str(out)]
    assert main([*argv, "--tasks", *tasks]) == 0
    return out / "prompting_samples.csv"


@pytest.mark.parametrize(
    ("method", "tasks"),
    [("flp", ("ol01-table2", "ol09-drawer4-from-start")), ("one-step", ("ol10-basket-bowl",))],
)
def test_the_published_offline_model_runs_replay_exactly(
    method: str, tasks: tuple[str, ...], tmp_path: Path
) -> None:
    replayed = _rows(_replay(method, tasks, tmp_path), (method,), tasks)
    published = _rows(PUBLISHED, (method,), tasks)
    assert replayed and replayed == published


PROTOCOLS = ROOT / "docs" / "results" / "prompting-qwen1.5b-protocols-ol_samples.csv"


def test_the_papers_protocol_rows_replay_exactly(tmp_path: Path) -> None:
    """The same model in the paper's protocol (recorded in the run that measured both
    protocols): its answers replay to the same goals and verdicts."""
    tasks = ("ol01-table2", "ol05-drawer3")
    csv_path = _replay("one-step", tasks, tmp_path, "--protocol", "paper")
    replayed = _rows(csv_path, ("one-step [paper]",), tasks)
    published = _rows(PROTOCOLS, ("one-step [paper]",), tasks)
    assert replayed and replayed == published
    assert all(r["success"] == "False" for r in replayed.values())


SUITE = ROOT / "docs" / "results" / "prompting-qwen1.5b-suite-partial_samples.csv"


@pytest.mark.parametrize(
    ("method", "tasks"),
    [
        ("flp-refer", ("sc10-apple-waxed-cook-and-serve", "ab17-fridge-open-cube")),
        ("one-step", ("sc14-bread-greasy-cool-and-serve",)),
    ],
)
def test_the_whole_suite_runs_replay_exactly(
    method: str, tasks: tuple[str, ...], tmp_path: Path
) -> None:
    """A slice of the whole-suite run (recorded in two sittings, the table in
    docs/llm-part.md) replays to the same goals and verdicts."""
    replayed = _rows(_replay(method, tasks, tmp_path), (method,), tasks)
    published = _rows(SUITE, (method,), tasks)
    assert replayed and replayed == published


CHOOSE = ROOT / "docs" / "results" / "prompting-qwen1.5b-choose_samples.csv"


def test_the_choosing_run_replays_exactly(tmp_path: Path) -> None:
    """A slice of the #31 run (flp-choose: the model's scores of the loop's candidates,
    recorded as ``score`` cassettes; its first looks are FLP's recorded ones) replays to the
    same goals and verdicts (docs/results/prompting-qwen1.5b-choose.md)."""
    tasks = ("ol01-table2", "ol02-table1")
    # recorded before #35's sweeps: one place a consultation, as the loop searched then
    csv_path = _replay("flp-choose", tasks, tmp_path, "--sweep-places", "1")
    replayed = _rows(csv_path, ("flp-choose",), tasks)
    published = _rows(CHOOSE, ("flp-choose",), tasks)
    assert replayed and replayed == published
    assert {r["success"] for r in replayed.values()} == {"True", "False"}
