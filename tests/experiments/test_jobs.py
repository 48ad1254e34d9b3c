"""The resumable job runner: results are cached per key, a resumed run only does what is
missing, parallel runs give the same results in job order, errors keep finished work."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from llmpas.experiments.jobs import Job, cache_file, cached, fingerprint, run_jobs


def square(n: int) -> dict[str, Any]:
    if n < 0:
        raise ValueError("negative")
    return {"value": n * n}


def quiet() -> Console:
    return Console(file=io.StringIO())


def test_results_come_back_in_job_order_and_are_cached(tmp_path: Path) -> None:
    jobs = [Job(f"n={n}", n) for n in (3, 1, 2)]
    out = run_jobs(jobs, square, tmp_path, console=quiet())
    assert [r["value"] for r in out] == [9, 1, 4]
    assert cached(tmp_path, "n=1") == {"key": "n=1", "value": 1}
    assert cached(tmp_path, "n=4") is None


def test_resume_runs_only_missing_jobs(tmp_path: Path) -> None:
    calls: list[int] = []

    def counting(n: int) -> dict[str, Any]:
        calls.append(n)
        return square(n)

    run_jobs([Job("a", 1), Job("b", 2)], counting, tmp_path, console=quiet())
    out = run_jobs([Job("a", 1), Job("b", 2), Job("c", 3)], counting, tmp_path, console=quiet())
    assert calls == [1, 2, 3]
    assert [r["value"] for r in out] == [1, 4, 9]


def test_an_error_keeps_finished_results_and_resume_continues(tmp_path: Path) -> None:
    jobs = [Job("ok", 2), Job("bad", -1), Job("later", 3)]
    with pytest.raises(ValueError, match="negative"):
        run_jobs(jobs, square, tmp_path, console=quiet())
    assert cached(tmp_path, "ok") is not None
    assert cached(tmp_path, "bad") is None
    assert not list(tmp_path.glob(".*tmp"))  # nothing half-written


def test_parallel_workers_give_the_same_results(tmp_path: Path) -> None:
    jobs = [Job(f"n={n}", n) for n in range(6)]
    out = run_jobs(jobs, square, tmp_path / "par", workers=2, console=quiet())
    assert [r["value"] for r in out] == [n * n for n in range(6)]


def test_corrupt_cache_file_is_redone(tmp_path: Path) -> None:
    cache_file(tmp_path, "x").write_text("{not json")
    out = run_jobs([Job("x", 4)], square, tmp_path, console=quiet())
    assert out[0]["value"] == 16
    assert json.loads(cache_file(tmp_path, "x").read_text())["result"] == {"value": 16}


def test_duplicate_keys_and_bad_worker_counts_are_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="duplicate job keys: a"):
        run_jobs([Job("a", 1), Job("a", 2)], square, tmp_path)
    with pytest.raises(ValueError, match="workers"):
        run_jobs([Job("a", 1)], square, tmp_path, workers=0)


def test_fingerprint_is_stable_and_sensitive() -> None:
    assert fingerprint({"a": 1, "b": 2}) == fingerprint({"b": 2, "a": 1})
    assert fingerprint({"a": 1}) != fingerprint({"a": 2})


def test_long_keys_give_short_unique_file_names(tmp_path: Path) -> None:
    a, b = "k" * 200 + "1", "k" * 200 + "2"
    assert cache_file(tmp_path, a) != cache_file(tmp_path, b)
    assert len(cache_file(tmp_path, a).name) < 140
