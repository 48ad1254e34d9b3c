"""The one benchmark harness (#46 item 2): every ``llmpas bench`` command's shared options and
trials come from :mod:`llmpas.experiments.harness`, never from the benchmark's own module."""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from llmpas.experiments.benchmarks import Benchmark, benchmarks
from llmpas.experiments.harness import (
    Harnessed,
    Shared,
    SharedOptions,
    add_shared_arguments,
    rows_of,
    shared_from_args,
)
from llmpas.experiments.jobs import ExecutorSpec

SRC = Path(__file__).parents[2] / "src" / "llmpas" / "experiments"


def _parser(benchmark: Benchmark) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser()
    benchmark.add_arguments(p)
    return p


def test_the_shared_options_are_declared_in_the_harness_only() -> None:
    declared = re.compile(r"""add_argument\(\s*["'](--jobs|--out|--executor|--ray-address)["']""")
    found = [
        str(path.relative_to(SRC))
        for path in SRC.rglob("*.py")
        if declared.search(path.read_text(encoding="utf-8"))
    ]
    assert sorted(found) == ["harness.py", "jobs.py"]


@pytest.mark.parametrize("bench", benchmarks(), ids=lambda b: b.name)
def test_each_benchmark_reads_its_shared_options_back(bench: Benchmark) -> None:
    p = _parser(bench)
    names = {a.dest for a in p._actions}
    if not isinstance(bench, Harnessed):
        return  # report, ros, live, validate-data: no trials of their own to cache
    options = bench.shared
    assert ("jobs" in names) == options.jobs and ("out" in names) == (options.out is not None)
    assert ("executor" in names) == options.executor
    positional = ["x" for a in p._actions if not a.option_strings and a.required]
    argv = [
        *positional,
        *(["--jobs", "3"] if options.jobs else []),
        *(["--out", "x/y"] if options.out else []),
    ]
    known, _ = p.parse_known_args(argv)
    shared = shared_from_args(known)
    assert shared.jobs == (3 if options.jobs else 1)
    assert shared.out_dir == (Path("x/y") if options.out else Shared().out_dir)
    assert shared.executor == ExecutorSpec()


def test_the_shared_options_follow_the_declaration() -> None:
    p = argparse.ArgumentParser()
    add_shared_arguments(p, SharedOptions(out="results/x", jobs_help="runs", executor=True))
    args = p.parse_args(["--executor", "ray", "--ray-address", "auto"])
    assert shared_from_args(args) == Shared(Path("results/x"), 1, ExecutorSpec("ray", "auto"))
    q = argparse.ArgumentParser()
    add_shared_arguments(q, SharedOptions(jobs=False, executor=False))
    assert {a.dest for a in q._actions} == {"help"}
    with pytest.raises(ValueError, match="--ray-address"):
        shared_from_args(p.parse_args(["--ray-address", "auto"]))


@dataclass(frozen=True)
class _Row:
    name: str
    value: int


def test_a_cached_result_becomes_its_row() -> None:
    results = [{"key": "a/1", "name": "a", "value": 1, "jobs": 2}, {"name": "b", "value": 2}]
    assert rows_of(_Row, results) == [_Row("a", 1), _Row("b", 2)]
