"""The planning-time benchmark writes its CSV, table and plot (tiny sizes; no timing claims)."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from rich.console import Console

from llmpas.experiments.planning_time import BenchConfig, markdown_table, run_planning_time


def test_bench_writes_csv_table_and_plot(tmp_path: Path) -> None:
    config = BenchConfig(
        examples=("mobile",), trials=2, max_time=30, sizes=(1, 2), out_dir=tmp_path
    )
    report = run_planning_time(config, Console(file=open("/dev/null", "w")))  # noqa: SIM115
    names = {p.name for p in report.files}
    assert names == {"planning_time.csv", "planning_time.md", "planning_time.png"}
    rows = list(csv.DictReader((tmp_path / "planning_time.csv").open()))
    assert len(rows) == 2 * 2 * 2  # sizes x trials x modes
    assert {r["mode"] for r in rows} == {"deferred", "eager"}
    assert all(r["status"] == "solved" for r in rows)
    # deferred runs never call the deferred streams; eager ones do
    by_mode = {
        m: [int(r["stream_calls"]) for r in rows if r["mode"] == m] for m in ("deferred", "eager")
    }
    assert max(by_mode["deferred"]) < min(by_mode["eager"])
    table = (tmp_path / "planning_time.md").read_text()
    assert "| mobile | 1 |" in table and "| mobile | 2 |" in table
    png = (tmp_path / "planning_time.png").read_bytes()
    assert png.startswith(b"\x89PNG")
    assert not list(tmp_path.glob("*.tmp*"))


def test_markdown_marks_unsolved_sizes() -> None:
    from llmpas.experiments.planning_time import Row

    row = Row("mobile", 8, {"deferred": 2.0, "eager": None}, {"deferred": 5, "eager": 0}, 5)
    text = markdown_table([row], BenchConfig(examples=("mobile",)))
    assert "| mobile | 8 | 2.00 | 5/5 | — | 0/5 | — |" in text


@pytest.mark.parametrize(
    "bad", [{"trials": 0}, {"max_time": 0}, {"sizes": ()}, {"examples": ("nosuch",)}]
)
def test_bad_configuration_is_rejected(bad: dict[str, object]) -> None:
    with pytest.raises((ValueError, KeyError)):
        BenchConfig(**bad)  # type: ignore[arg-type]
