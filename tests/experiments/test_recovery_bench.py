"""``llmpas bench recovery`` (issue #42 item 4): every run kept, each consultation's checks read
back from ``loop.json`` with how each was decided, and the report written."""

from __future__ import annotations

import csv
from pathlib import Path

from llmpas.cli import main
from llmpas.experiments.recovery_bench import read_runs
from llmpas.system.records import DECIDED_BY


def test_the_recovery_report_lists_each_check_and_how_it_was_decided(tmp_path: Path) -> None:
    out = tmp_path / "rec"
    argv = ["bench", "recovery", "--tasks", "ab06-sink-mug", "--no-oracle", "--no-replan"]
    argv += ["--methods", "candidates-first", "--out", str(out)]
    assert main(argv) == 0
    runs = read_runs(out / "runs")
    assert [(r.row, r.task) for r in runs] == [("candidates-first", "ab06-sink-mug")]
    checks = [ch for c in runs[0].consultations for ch in c.checks]
    assert checks and all(ch["by"] in DECIDED_BY for ch in checks)
    assert any(ch["verdict"] == "accepted" for ch in checks)
    assert runs[0].plans and "timeout" not in runs[0].plans  # every plan decided by counts
    md = (out / "recovery.md").read_text()
    assert "| candidates-first | 1 |" in md and "## The slowest consultations" in md
    with (out / "recovery.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(checks) and rows[0]["task"] == "ab06-sink-mug"
    assert (out / "recovery.png").stat().st_size > 0
