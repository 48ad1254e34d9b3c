"""``llmpas bench tamp``: settings, the size-by-size skip, the table, and a tiny real run."""

from __future__ import annotations

import csv
import io
import json
import statistics
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments import tamp_bench
from llmpas.experiments.tamp_bench import REFERENCE_LABEL, Payload, TampBenchConfig, run_tamp


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def test_bad_settings() -> None:
    for bad in ({"families": ("spiral",)}, {"sizes": (0,)}, {"trials": 0}, {"max_time": 0.0}):
        with pytest.raises(ValueError):
            TampBenchConfig(**bad)  # type: ignore[arg-type]


def test_bad_options_are_one_line_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "tamp", "--trials", "0", "--out", "unused"]) == 2
    assert "trials" in capsys.readouterr().err


def _fake(solves: set[tuple[str, str]]) -> Any:
    """A stand-in for a trial: solved (CPU grows with the size) for the given (family, mode)."""

    def run(p: Payload) -> dict[str, Any]:
        ok = (p.family, p.mode) in solves
        return {
            **tamp_bench._failed(p, "solved" if ok else "timeout", "ok" if ok else "no plan"),
            "valid": ok,
            "cpu": 0.1 * p.size * (1 if p.mode == "deferred" else 10),
        }

    return run


def test_a_mode_that_solves_nothing_is_not_run_at_larger_sizes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(
        tamp_bench, "run_job", _fake({("mirror", "deferred"), ("packed", "computed")})
    )
    config = TampBenchConfig(sizes=(1, 2, 3), trials=2, out_dir=tmp_path)
    report = run_tamp(config, quiet())
    ran = {(t.family, t.mode, t.size) for t in report.trials}
    assert ("mirror", "deferred", 3) in ran and ("packed", "computed", 3) in ran
    assert ("mirror", "computed", 1) in ran and ("mirror", "computed", 2) not in ran
    table = (tmp_path / "tamp.md").read_text()
    assert "| mirror | 2 | not run | — | — | 0.20 | — | 2/2 |" in table
    assert REFERENCE_LABEL in table
    assert tamp_bench.cpu_share(report.trials) == pytest.approx(
        statistics.median(t.cpu / t.wall for t in report.trials if t.solved)
    )
    assert "Median CPU / wall of the solved trials" in table
    rows = {(r.family, r.size): r for r in report.rows}
    assert rows["packed", 3].cpu["computed"] == pytest.approx(3.0)
    assert rows["packed", 3].solved == {"computed": 2, "deferred": 0}
    # with --keep-going every size runs
    keep = TampBenchConfig(sizes=(1, 2), trials=1, out_dir=tmp_path / "k", keep_going=True)
    assert len(run_tamp(keep, quiet()).trials) == 2 * 2 * 2


def test_cost_columns_per_quality_and_the_anytime_plot(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def run(p: Payload) -> dict[str, Any]:
        base = 100.0 * p.size + p.trial  # fast's cost; optimal 10 % cheaper; anytime improves
        final = {"fast": base, "optimal": 0.9 * base, "anytime": 0.8 * base}[p.quality]
        steps = [[0.1, base], [0.5, final]] if p.quality == "anytime" else [[0.2, final]]
        return {
            **tamp_bench._failed(p, "solved", "ok"),
            "valid": True,
            "cpu": 1.0 + p.size,
            "wall": 1.0 + p.size,
            "cost": final,
            "improvements": json.dumps(steps),
        }

    monkeypatch.setattr(tamp_bench, "run_job", run)
    config = TampBenchConfig(
        sizes=(1, 2),
        trials=3,
        out_dir=tmp_path,
        modes=("computed",),
        qualities=("fast", "anytime", "optimal"),
    )
    assert config.columns == ("computed", "computed+anytime", "computed+optimal")
    report = run_tamp(config, quiet())
    rows = {(r.family, r.size): r for r in report.rows}
    assert rows["packed", 2].cost == {
        "computed": 201.0,
        "computed+anytime": pytest.approx(160.8),
        "computed+optimal": pytest.approx(180.9),
    }
    table = (tmp_path / "tamp.md").read_text()
    assert "computed+anytime CPU (s) | cost | solved" in table
    assert "| packed | 2 | 3.00 | 201.0 | 3/3 | 3.00 | 160.8 | 3/3 | 3.00 | 180.9 | 3/3 |" in table
    assert (tmp_path / "tamp-anytime.png").read_bytes()[:4] == b"\x89PNG"
    anytime = [t for t in report.trials if t.quality == "anytime"]
    assert all(t.timeline() == [(0.1, 100.0 * t.size + t.trial), (0.5, t.cost)] for t in anytime)
    with (tmp_path / "tamp.csv").open() as f:
        assert {r["quality"] for r in csv.DictReader(f)} == {"fast", "anytime", "optimal"}
    with pytest.raises(ValueError, match="unknown mode or quality"):
        TampBenchConfig(qualities=("best",))
    with pytest.raises(ValueError, match=r"no domain\.pddl"):
        TampBenchConfig(files=tmp_path)


def test_an_invalid_plan_is_not_counted_as_solved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def invalid(p: Payload) -> dict[str, Any]:
        return {**tamp_bench._failed(p, "solved", "geometry: b1 collides"), "cpu": 0.5}

    monkeypatch.setattr(tamp_bench, "run_job", invalid)
    report = run_tamp(TampBenchConfig(sizes=(1,), trials=1, out_dir=tmp_path), quiet())
    assert not any(t.solved for t in report.trials)
    assert "0/1, 1 invalid" in (tmp_path / "tamp.md").read_text()


def test_a_tiny_real_run_writes_table_plot_and_cache(tmp_path: Path) -> None:
    out = tmp_path / "tamp"
    argv = ["bench", "tamp", "--sizes", "1", "--trials", "1", "--max-time", "60"]
    assert main([*argv, "--out", str(out)]) == 0
    with (out / "tamp.csv").open() as f:
        trials = list(csv.DictReader(f))
    assert {(t["family"], t["mode"]) for t in trials} == {
        (f, m) for f in ("mirror", "packed") for m in ("computed", "deferred")
    }
    for t in trials:
        assert t["status"] == "solved" and t["valid"] == "True", t
        assert float(t["cpu"]) > 0 and int(t["plan_length"]) >= 5
        assert float(t["cost"]) > 0 and json.loads(t["improvements"])[-1][1] > 0
    assert (out / "tamp.png").read_bytes()[:4] == b"\x89PNG"
    assert "| mirror | 1 |" in (out / "tamp.md").read_text()
    cached = sorted((out / "cache").glob("*.json"))
    assert len(cached) == 4
    before = [p.read_text() for p in cached]
    assert main([*argv, "--out", str(out)]) == 0  # resumed from the cache: nothing re-run
    assert [p.read_text() for p in cached] == before


def test_a_trial_past_its_deadline_is_killed_and_a_failing_one_reported(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(tamp_bench, "KILL_GRACE", 0.0)
    late = tamp_bench.run_job(Payload("mirror", 1, "computed", 0, 0.001, 3072, 1))
    assert late["status"] == "killed" and not late["valid"]
    monkeypatch.setattr(tamp_bench, "KILL_GRACE", 30.0)
    bad = tamp_bench.run_job(Payload("spiral", 1, "computed", 0, 5.0, 3072, 1))
    assert bad["status"] == "crashed" and "unknown family" in bad["validation"]
