"""The perturbation benchmark: one cached job per (episode, mode), resumable, parallel runs give
the same outcomes, and it writes the CSV, the table and a grouped bar chart."""

from __future__ import annotations

import csv
import io
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from PIL import Image
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments import perturbation
from llmpas.experiments.perturbation import (
    Outcome,
    PerturbationConfig,
    by_kind,
    episode_data,
    kinds,
    run_perturbation,
)


def quiet() -> Console:
    return Console(file=io.StringIO())


def colours(path: Path) -> set[tuple[int, ...]]:
    with Image.open(path) as image:
        found = image.convert("RGB").getcolors(maxcolors=1 << 24)
    assert found is not None
    return {c for _, c in found if isinstance(c, tuple)}


def cache_files(config: PerturbationConfig) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in (config.out_dir / "cache").glob("*.json")}


def without_time(outcomes: list[Outcome]) -> list[tuple[Any, ...]]:
    return [(o.episode, o.mode, o.disturbances, o.status, o.retries, o.ticks) for o in outcomes]


class FakeEpisodes:
    """Stands in for ``run_episode`` (no simulation): counts calls, may fail on one episode."""

    def __init__(self, fail_on: int | None = None) -> None:
        self.calls: list[tuple[int, str]] = []
        self.fail_on = fail_on

    def __call__(self, k: int, mode: str, config: PerturbationConfig) -> Outcome:
        if k == self.fail_on:
            raise RuntimeError(f"interrupted at episode {k}")
        self.calls.append((k, mode))
        status = "success" if mode == "csubbt" or k % 2 else "failure"
        return Outcome(k, mode, episode_data(k, config.seed)[1], status, k % 3, 2, 0.5)


def test_run_writes_csv_table_and_a_nonblank_plot_then_resumes_from_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = PerturbationConfig(episodes=1, seed=3, out_dir=tmp_path)
    outcomes, files = run_perturbation(config, quiet())
    assert [p.name for p in files] == ["perturbation.csv", "perturbation.md", "perturbation.png"]
    assert [(o.episode, o.mode) for o in outcomes] == [(0, "csubbt"), (0, "flat")]
    rows = list(csv.DictReader((tmp_path / "perturbation.csv").open()))
    assert [r["mode"] for r in rows] == ["csubbt", "flat"]
    assert "1 seeded episodes (seed 3), no LLM" in (tmp_path / "perturbation.md").read_text()
    png = tmp_path / "perturbation.png"
    assert png.read_bytes().startswith(b"\x89PNG")
    found = colours(png)
    assert len(found) > 1
    assert (31, 119, 180) in found  # the csubbt bars (tab:blue) are drawn
    before = cache_files(config)
    assert len(before) == 2

    def no_rerun(*_: object) -> Outcome:
        raise AssertionError("a cached episode was run again")

    monkeypatch.setattr(perturbation, "run_episode", no_rerun)
    again, _ = run_perturbation(config, quiet())
    assert again == outcomes  # every result, time included, comes from the cache
    assert cache_files(config) == before
    assert not list(tmp_path.rglob("*.tmp"))


def test_an_interrupted_run_resumes_with_the_missing_episodes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = PerturbationConfig(episodes=3, out_dir=tmp_path)
    monkeypatch.setattr(perturbation, "run_episode", FakeEpisodes(fail_on=1))
    with pytest.raises(RuntimeError, match="interrupted"):
        run_perturbation(config, quiet())
    fake = FakeEpisodes()
    monkeypatch.setattr(perturbation, "run_episode", fake)
    outcomes, _ = run_perturbation(config, quiet())
    assert fake.calls == [(1, "csubbt"), (1, "flat"), (2, "csubbt"), (2, "flat")]
    assert [(o.episode, o.mode) for o in outcomes] == [
        (k, m) for k in range(3) for m in ("csubbt", "flat")
    ]


@pytest.mark.parametrize(
    ("change", "reruns"),
    [
        ({"max_time": 5.0}, 4),  # a changed planning limit redoes every episode
        ({"seed": 1}, 4),  # other episodes
        ({"episodes": 3}, 2),  # only the new episode
        ({"jobs": 2}, 0),  # the same episodes and settings: everything is cached
    ],
)
def test_changed_settings_do_not_reuse_cached_results(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change: dict[str, Any], reruns: int
) -> None:
    config = PerturbationConfig(episodes=2, out_dir=tmp_path)
    monkeypatch.setattr(perturbation, "run_episode", FakeEpisodes())
    run_perturbation(config, quiet())
    fake = FakeEpisodes()
    monkeypatch.setattr(perturbation, "run_episode", fake)
    run_perturbation(replace(config, **change), quiet())
    assert len(fake.calls) == reruns


def test_two_jobs_give_the_same_outcomes_as_one(tmp_path: Path) -> None:
    one = PerturbationConfig(episodes=2, out_dir=tmp_path / "one")
    two = replace(one, out_dir=tmp_path / "two", jobs=2)
    serial, _ = run_perturbation(one, quiet())
    parallel, _ = run_perturbation(two, quiet())
    assert without_time(parallel) == without_time(serial)
    assert (tmp_path / "one" / "perturbation.md").read_text() == (
        tmp_path / "two" / "perturbation.md"
    ).read_text()
    assert len(cache_files(two)) == 4


def test_disturbance_kinds_and_success_per_kind() -> None:
    assert kinds("pose 0.011+miss 0.0+slip+moved-on-table") == ("pose", "slip", "moved-on-table")
    assert kinds("pose 0.000+miss 0.2") == ("miss",)
    outcomes = [
        Outcome(0, "csubbt", "pose 0.010+miss 0.0+slip", "success", 1, 2, 1.0),
        Outcome(0, "flat", "pose 0.010+miss 0.0+slip", "failure", 0, 1, 1.0),
        Outcome(1, "csubbt", "pose 0.002+miss 0.1", "success", 0, 1, 1.0),
        Outcome(1, "flat", "pose 0.002+miss 0.1", "success", 0, 1, 1.0),
    ]
    table = by_kind(outcomes)
    assert list(table) == ["all", "pose", "miss", "slip"]
    assert table["all"] == {"csubbt": (2, 2), "flat": (1, 2)}
    assert table["slip"] == {"csubbt": (1, 1), "flat": (0, 1)}
    assert table["miss"] == {"csubbt": (1, 1), "flat": (1, 1)}


@pytest.mark.parametrize("bad", [{"episodes": 0}, {"jobs": 0}, {"jobs": -2}])
def test_bad_configuration_is_rejected(bad: dict[str, int]) -> None:
    with pytest.raises(ValueError):
        PerturbationConfig(**bad)  # type: ignore[arg-type]


def test_cli_passes_jobs_through(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[PerturbationConfig] = []

    def fake(config: PerturbationConfig, console: Console) -> tuple[list[Outcome], list[Path]]:
        seen.append(config)
        return [], []

    monkeypatch.setattr(perturbation, "run_perturbation", fake)
    args = ["bench", "perturbation", "--episodes", "4", "--out", str(tmp_path)]
    assert main([*args, "--jobs", "2"]) == 0
    assert seen == [PerturbationConfig(episodes=4, out_dir=tmp_path, jobs=2)]
    assert main([*args, "--jobs", "0"]) == 2  # a one-line error
