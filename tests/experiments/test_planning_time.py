"""The planning-time benchmark writes its CSV, table and plot (tiny sizes; no timing claims);
each trial is a cached job, so a run resumes, and parallel timings are flagged as contended."""

from __future__ import annotations

import csv
import io
import logging
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from PIL import Image
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments import planning_time
from llmpas.experiments.planning_time import (
    BenchConfig,
    Report,
    Trial,
    markdown_table,
    planner_config,
    run_planning_time,
)


def quiet() -> Console:
    return Console(file=io.StringIO())


def cache_files(config: BenchConfig) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in (config.out_dir / "cache").glob("*.json")}


class FakeTrials:
    """Stands in for ``run_trial`` (no planning): counts calls, may fail on one size."""

    def __init__(self, fail_on: int | None = None) -> None:
        self.calls: list[tuple[str, int, str, int]] = []
        self.fail_on = fail_on

    def __call__(self, example: str, size: int, mode: str, trial: int, c: BenchConfig) -> Trial:
        if size == self.fail_on:
            raise RuntimeError(f"interrupted at size {size}")
        self.calls.append((example, size, mode, trial))
        t = 0.1 * size * (3 if mode == "computed" else 1) + 0.01 * trial
        return Trial(example, size, mode, trial, "solved", t, t / 2, 0.0, t / 2, size, size)


def test_bench_writes_csv_table_and_plot(tmp_path: Path) -> None:
    config = BenchConfig(
        examples=("mobile",), trials=2, max_time=30, sizes=(1, 2), out_dir=tmp_path
    )
    report = run_planning_time(config, Console(file=open("/dev/null", "w")))  # noqa: SIM115
    names = {p.name for p in report.files}
    assert names == {"planning_time.csv", "planning_time.md", "planning_time.png"}
    rows = list(csv.DictReader((tmp_path / "planning_time.csv").open()))
    assert len(rows) == 2 * 2 * 2  # sizes x trials x modes
    assert {r["mode"] for r in rows} == {"deferred", "computed"}
    assert all(r["status"] == "solved" for r in rows)
    # deferred runs never call the deferred streams; computed ones do (the same problem: the
    # same size and trial)
    calls = {(r["mode"], r["size"], r["trial"]): int(r["stream_calls"]) for r in rows}
    for (mode, size, trial), n in calls.items():
        if mode == "deferred":
            assert n < calls[("computed", size, trial)], (size, trial)
    assert all(float(r["cost"]) > 0 for r in rows)  # every trial solved: a plan cost
    table = (tmp_path / "planning_time.md").read_text()
    assert "| mobile | 1 |" in table and "| mobile | 2 |" in table
    assert "| deferred (s) | cost | solved | computed (s) | cost | solved |" in table
    assert all(r.cost["computed"] is not None for r in report.rows)
    assert "1 job: trials one at a time" in table
    png = (tmp_path / "planning_time.png").read_bytes()
    assert png.startswith(b"\x89PNG")
    with Image.open(tmp_path / "planning_time.png") as image:
        assert len(image.convert("RGB").getcolors(maxcolors=1 << 24) or []) > 1  # not blank
    assert not list(tmp_path.glob("*.tmp*"))
    assert len(cache_files(config)) == 8  # one cached result per trial


def test_a_second_run_reads_every_trial_from_the_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = BenchConfig(examples=("mobile",), trials=2, sizes=(1, 2), out_dir=tmp_path)
    monkeypatch.setattr(planning_time, "run_trial", FakeTrials())
    first = run_planning_time(config, quiet())
    before = cache_files(config)
    assert len(before) == 8

    def no_rerun(*_: object) -> Trial:
        raise AssertionError("a cached trial was run again")

    monkeypatch.setattr(planning_time, "run_trial", no_rerun)
    second = run_planning_time(config, quiet())
    assert second.trials == first.trials and second.rows == first.rows
    assert cache_files(config) == before


def test_an_interrupted_run_resumes_with_the_missing_trials(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = BenchConfig(examples=("mobile",), trials=1, sizes=(1, 2), out_dir=tmp_path)
    monkeypatch.setattr(planning_time, "run_trial", FakeTrials(fail_on=2))
    with pytest.raises(RuntimeError, match="interrupted"):
        run_planning_time(config, quiet())
    fake = FakeTrials()
    monkeypatch.setattr(planning_time, "run_trial", fake)
    report = run_planning_time(config, quiet())
    assert fake.calls == [("mobile", 2, "deferred", 0), ("mobile", 2, "computed", 0)]
    assert [(t.size, t.mode) for t in report.trials] == [
        (1, "deferred"),
        (1, "computed"),
        (2, "deferred"),
        (2, "computed"),
    ]


@pytest.mark.parametrize(
    ("change", "reruns"),
    [
        ({"max_time": 5.0}, 4),  # a changed limit redoes every trial
        ({"algorithm": "incremental"}, 4),
        ({"trials": 3}, 2),  # only the new trial, in both modes
        ({"sizes": (1, 2)}, 4),  # only the new size (2 trials x 2 modes)
        ({"jobs": 2}, 0),  # the same settings: everything is cached
    ],
)
def test_changed_settings_do_not_reuse_cached_results(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change: dict[str, Any], reruns: int
) -> None:
    config = BenchConfig(examples=("mobile",), trials=2, sizes=(1,), out_dir=tmp_path)
    monkeypatch.setattr(planning_time, "run_trial", FakeTrials())
    run_planning_time(config, quiet())
    fake = FakeTrials()
    monkeypatch.setattr(planning_time, "run_trial", fake)
    run_planning_time(replace(config, **change), quiet())
    assert len(fake.calls) == reruns


def test_parallel_timings_are_flagged_as_contended(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    config = BenchConfig(examples=("mobile",), trials=1, sizes=(1,), out_dir=tmp_path, jobs=2)
    with caplog.at_level(logging.WARNING, logger=planning_time.__name__):
        report = run_planning_time(config, quiet())
    assert [t.status for t in report.trials] == ["solved", "solved"]
    assert "timings measured in parallel are contended" in caplog.text
    table = (tmp_path / "planning_time.md").read_text()
    assert "2 parallel jobs: timings contended" in table
    # resumed with one job, the cached timings still say they were measured in parallel
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger=planning_time.__name__):
        again = run_planning_time(replace(config, jobs=1), quiet())
    assert again.trials == report.trials
    assert "measured with 2 parallel jobs" in caplog.text
    assert "2 parallel jobs: timings contended" in (tmp_path / "planning_time.md").read_text()


def test_cli_passes_jobs_through(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[BenchConfig] = []

    def fake(config: BenchConfig, console: Console) -> Report:
        seen.append(config)
        return Report((), ())

    monkeypatch.setattr(planning_time, "run_planning_time", fake)
    args = ["bench", "planning-time", "--examples", "mobile", "--out", str(tmp_path)]
    assert main([*args, "--jobs", "2"]) == 0
    assert seen == [BenchConfig(examples=("mobile",), out_dir=tmp_path, jobs=2)]
    assert main([*args, "--jobs", "0"]) == 2  # a one-line error


def test_markdown_marks_unsolved_sizes() -> None:
    from llmpas.experiments.planning_time import Row

    row = Row("mobile", 8, {"deferred": 2.0, "computed": None}, {"deferred": 5, "computed": 0}, 5)
    text = markdown_table([row], BenchConfig(examples=("mobile",)))
    assert "| mobile | 8 | 2.00 | — | 5/5 | — | — | 0/5 | — |" in text
    assert "; 1 job: trials one at a time)" in text.splitlines()[0]
    parallel = markdown_table([row], BenchConfig(examples=("mobile",), jobs=3))
    assert "; 3 parallel jobs: timings contended)" in parallel.splitlines()[0]


@pytest.mark.parametrize(
    "bad",
    [{"trials": 0}, {"max_time": 0}, {"sizes": ()}, {"examples": ("nosuch",)}, {"jobs": 0}],
)
def test_bad_configuration_is_rejected(bad: dict[str, object]) -> None:
    with pytest.raises((ValueError, KeyError)):
        BenchConfig(**bad)  # type: ignore[arg-type]


def test_the_old_eager_spelling_still_means_computed_but_warns() -> None:
    config = BenchConfig(examples=("mobile",), trials=1)
    with pytest.warns(DeprecationWarning, match="'eager' is deprecated; say 'computed'"):
        old = planner_config("eager", 0, config)
    assert old == planner_config("computed", 0, config)
    assert not old.defer and planner_config("deferred", 0, config).defer
    with pytest.raises(ValueError, match="mode must be one of"):
        planner_config("lazy", 0, config)
