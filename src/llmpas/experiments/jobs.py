"""Resumable experiment jobs: each job's result is a JSON file in a cache folder, written
atomically as soon as the job ends, so an interrupted run resumes where it stopped; jobs can run
in parallel processes; a rich progress bar shows how far the run is.

A job's key names its cache file: put everything that changes the result into it (method,
task, sample, and a :func:`fingerprint` of the configuration), so that a changed configuration
never reuses stale results.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any, Generic, TypeVar

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from llmpas.files import atomic_write

log = logging.getLogger(__name__)

P = TypeVar("P")
Result = dict[str, Any]
_SAFE = re.compile(r"[^A-Za-z0-9_.=-]+")


@dataclass(frozen=True)
class Job(Generic[P]):
    """One unit of work: ``key`` (unique, names the cache file) and a picklable payload."""

    key: str
    payload: P

    def __post_init__(self) -> None:
        if not self.key.strip():
            raise ValueError("a job needs a non-empty key")


@cache
def backend(spec: str, record: str | None = None) -> Any:
    """The LLM backend for a ``--llm`` spec, built once per process (a worker loads a local model
    once, not per job). ValueError for a bad spec."""
    from llmpas.cli import CliError, _llm

    try:
        return _llm(spec, record)
    except CliError as err:
        raise ValueError(str(err)) from None


def add_llm_argument(p: argparse.ArgumentParser, oracle: str = "oracle") -> None:
    """The ``--llm`` option every experiment takes (``oracle`` says what the oracle is there)."""
    p.add_argument(
        "--llm",
        default="llama-cpp",
        help=f"{oracle} | replay:DIR | openai:MODEL[@BASE_URL] | llama-cpp[:PATH] "
        "(default: the offline model)",
    )


def fingerprint(value: Any, length: int = 10) -> str:
    """A short stable hash of a JSON-able value (a configuration), for cache keys."""
    text = json.dumps(value, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:length]


def cache_file(cache: Path, key: str) -> Path:
    name = _SAFE.sub("_", key)
    if len(name) > 120:  # keep file names short; the hash keeps them unique
        name = name[:100] + "-" + fingerprint(key)
    return cache / f"{name}.json"


def cached(cache: Path, key: str) -> Result | None:
    """The stored result of ``key``, or None (missing, or unreadable: it is redone)."""
    path = cache_file(cache, key)
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        log.warning("ignoring unreadable cached result %s: %s", path, err)
        return None
    return data if isinstance(data, dict) and data.get("key") == key else None


def _store(cache: Path, key: str, result: Mapping[str, Any]) -> Result:
    out = {"key": key, **result}
    atomic_write(cache_file(cache, key), json.dumps(out, indent=1, default=str))
    return out


@contextmanager
def progress_bar(
    console: Console | None, description: str, total: int
) -> Iterator[Callable[[], None]]:
    """A rich progress bar; yields a function that advances it by one."""
    console = console or Console(stderr=True)
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console, transient=False) as bar:
        task = bar.add_task(description, total=total)
        yield lambda: bar.advance(task)


def run_jobs(
    jobs: Sequence[Job[P]],
    work: Callable[[P], Mapping[str, Any]],
    cache: Path,
    *,
    workers: int = 1,
    description: str = "jobs",
    console: Console | None = None,
) -> list[Result]:
    """Run every job whose result is not cached yet and return all results in job order.

    ``work`` must be a module-level function when ``workers > 1`` (it runs in other
    processes). An exception in a job propagates after the finished jobs are stored, so the
    run can be resumed."""
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    keys = [j.key for j in jobs]
    if len(set(keys)) != len(keys):
        dup = sorted({k for k in keys if keys.count(k) > 1})
        raise ValueError(f"duplicate job keys: {', '.join(dup[:5])}")
    results: dict[str, Result] = {}
    todo: list[Job[P]] = []
    for job in jobs:
        hit = cached(cache, job.key)
        if hit is None:
            todo.append(job)
        else:
            results[job.key] = hit
    if results:
        log.info("%s: %d of %d results cached in %s", description, len(results), len(jobs), cache)
    with progress_bar(console, description, len(jobs)) as advance:
        for _ in results:
            advance()
        if workers == 1 or len(todo) <= 1:
            for job in todo:
                results[job.key] = _store(cache, job.key, work(job.payload))
                advance()
        else:
            _parallel(todo, work, cache, workers, results, advance)
    return [results[k] for k in keys]


def _parallel(
    todo: Sequence[Job[P]],
    work: Callable[[P], Mapping[str, Any]],
    cache: Path,
    workers: int,
    results: dict[str, Result],
    advance: Callable[[], None],
) -> None:
    with ProcessPoolExecutor(max_workers=workers) as pool:
        pending: dict[Future[Mapping[str, Any]], str] = {
            pool.submit(work, job.payload): job.key for job in todo
        }
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                key = pending.pop(future)
                try:
                    results[key] = _store(cache, key, future.result())
                except BaseException:
                    for other in pending:
                        other.cancel()
                    raise
                advance()


__all__ = ["Job", "backend", "cache_file", "cached", "fingerprint", "progress_bar", "run_jobs"]
