"""Resumable experiment jobs: each job's result is a JSON file in a cache folder, written
atomically as soon as the job ends, so an interrupted run resumes where it stopped; an
:class:`Executor` runs the jobs (in this process, in a local process pool, or on a Ray cluster:
:mod:`llmpas.experiments.cluster`); a rich progress bar shows how far the run is.

A job's key names its cache file: put everything that changes the result into it (method,
task, sample, and a :func:`fingerprint` of the configuration), so that a changed configuration
never reuses stale results.

Cache entries are written only by the process that runs :func:`run_jobs` (the driver), whichever
executor ran the job, so a cluster needs no shared folder. An entry carries a schema version and
the sha256 of its result; an entry that cannot be read, has another schema, lacks a field, or
whose result no longer matches its checksum is recomputed with a one-line warning, never used.
A result marked :func:`not_cacheable` (an infrastructure failure, not an outcome of the
experiment) and a job that raises are never stored.
"""

from __future__ import annotations

import argparse
import enum
import hashlib
import json
import logging
import os
import re
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

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
from llmpas.reasoning.backends.backend_registry import add_llm_argument
from llmpas.reasoning.replan import REPLAN
from llmpas.reasoning.truth_oracle import ORACLE

log = logging.getLogger(__name__)

P = TypeVar("P")
Result = dict[str, Any]
Work = Callable[[Any], Mapping[str, Any]]
_SAFE = re.compile(r"[^A-Za-z0-9_.=-]+")

SCHEMA = 2  # the cache entry format: {"schema", "key", "checksum", "result"}
MAX_ENTRY_BYTES = 64 << 20  # a larger cache file is not read (it is recomputed)
NOT_CACHEABLE = "_not_cacheable"  # a result holding this key (why) is returned, never stored
LLM_RESOURCE = "llm"  # the custom resource an LLM-bound job asks for on a cluster
EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class Job(Generic[P]):
    """One unit of work: ``key`` (unique, names the cache file), a picklable payload, and the
    resources it needs beyond one CPU on a cluster (e.g. ``{"llm": 1}``; ignored locally)."""

    key: str
    payload: P
    resources: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.key.strip():
            raise ValueError("a job needs a non-empty key")
        bad = [k for k, v in self.resources.items() if not k or not v > 0]
        if bad:
            raise ValueError(f"job {self.key}: resource {bad[0]!r} needs a name and an amount > 0")


def llm_resources(spec: str) -> dict[str, float]:
    """The resources of a job using the ``--llm`` backend ``spec``: one :data:`LLM_RESOURCE`
    when it talks to a model (a local model or an endpoint), none for the oracle or a replay."""
    kind = spec.partition(":")[0]
    return {} if kind in (ORACLE, REPLAN, "replay") else {LLM_RESOURCE: 1.0}


@cache
def backend(spec: str, record: str | None = None) -> Any:
    """The LLM backend for a ``--llm`` spec, built once per process (a worker loads a local model
    once, not per job). ValueError for a bad spec."""
    from llmpas.reasoning.backends.backend_registry import make_backend

    return make_backend(spec, record)


# ------------------------------------------------------------------------------ executors


@dataclass(frozen=True)
class ExecutorSpec:
    """Where jobs run: ``local`` (this machine: ``--jobs`` processes) or ``ray`` (a Ray
    cluster at ``address``; None: ``RAY_ADDRESS``, else a Ray instance started on this
    machine). ``retries``: how often a job whose worker was lost is run again."""

    kind: str = "local"
    address: str | None = None
    retries: int = 2

    def __post_init__(self) -> None:
        if self.kind not in EXECUTORS:
            raise ValueError(f"--executor {self.kind!r}: expected one of {', '.join(EXECUTORS)}")
        if self.address is not None and (self.kind != "ray" or not self.address.strip()):
            raise ValueError("--ray-address needs --executor ray and a non-empty address")
        if self.retries < 0:
            raise ValueError(f"retries must be >= 0, got {self.retries}")

    def argv(self) -> tuple[str, ...]:
        """The command-line options that select this executor."""
        if self.kind == "local":
            return ()
        return ("--executor", self.kind, *(("--ray-address", self.address) if self.address else ()))


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """The ``--executor`` and ``--ray-address`` options of every ``bench`` command."""
    p.add_argument(
        "--executor",
        choices=EXECUTORS,
        default="local",
        help="local: processes on this machine (--jobs); ray: a Ray cluster "
        "(pip install 'llmpas[cluster]'; see docs/cluster.md)",
    )
    p.add_argument(
        "--ray-address",
        help="with --executor ray: the cluster (HOST:6379, ray://HOST:10001 or auto; "
        "default: RAY_ADDRESS, else a Ray instance on this machine)",
    )


def executor_from_args(args: argparse.Namespace) -> ExecutorSpec:
    """The executor named by ``--executor``/``--ray-address`` (ValueError when they clash)."""
    return ExecutorSpec(getattr(args, "executor", "local"), getattr(args, "ray_address", None))


class ExecutorError(ValueError):
    """The executor cannot run the jobs (Ray missing, unreachable, or lacking a resource)."""


class JobsLost(RuntimeError):
    """Some jobs lost their worker on every attempt (the others finished and are cached)."""


class Outcome(enum.Enum):
    """What happened to a job, as counted on the progress bar."""

    CACHED = "cached"
    RAN = "ran"
    NOT_CACHED = "not cached"  # ran; the result is marked not cacheable
    RETRIED = "retried"  # an attempt lost its worker; the job runs again
    LOST = "lost"  # every attempt lost its worker


@dataclass(frozen=True)
class Event:
    """A job ended (``RAN``, with its result), an attempt was lost (``RETRIED``), or every
    attempt was (``LOST``, with ``detail`` saying how)."""

    key: str
    outcome: Outcome
    result: Mapping[str, Any] | None = None
    detail: str = ""


class Executor(Protocol):
    """Runs jobs somewhere and tells the driver as each one ends."""

    def run(self, jobs: Sequence[Job[Any]], work: Work) -> Iterator[Event]:
        """Yield one ``RAN`` or ``LOST`` event per job (any order) and ``RETRIED`` events. A
        job's exception propagates; closing the iterator stops the jobs still running."""
        ...


@dataclass(frozen=True)
class LocalExecutor:
    """``workers`` processes on this machine (one: in this process, job after job)."""

    workers: int = 1

    def __post_init__(self) -> None:
        if self.workers < 1:
            raise ValueError(f"workers must be >= 1, got {self.workers}")

    def run(self, jobs: Sequence[Job[Any]], work: Work) -> Iterator[Event]:
        if self.workers == 1 or len(jobs) <= 1:
            for job in jobs:
                yield Event(job.key, Outcome.RAN, work(job.payload))
            return
        pool = ProcessPoolExecutor(
            max_workers=self.workers, initializer=share_cores, initargs=(self.workers,)
        )
        try:
            pending: dict[Future[Mapping[str, Any]], str] = {
                pool.submit(work, job.payload): job.key for job in jobs
            }
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield Event(pending.pop(future), Outcome.RAN, future.result())
        finally:  # an error, Ctrl-C or a closed iterator: drop what has not started
            pool.shutdown(wait=True, cancel_futures=True)


def share_cores(jobs: int) -> None:
    """In a worker process of ``jobs``: a local model there takes its share of the free cores
    (:func:`~llmpas.reasoning.backends.llamacpp.free_cores`), not all of them."""
    from llmpas.reasoning.backends.llamacpp import JOBS_VARIABLE

    os.environ[JOBS_VARIABLE] = str(jobs)


def make_executor(spec: ExecutorSpec, workers: int = 1) -> Executor:
    """The executor for ``spec`` (``workers``: the local pool's size)."""
    if spec.kind == "ray":
        from llmpas.experiments.cluster import RayExecutor

        return RayExecutor(spec.address, spec.retries)
    return LocalExecutor(workers)


# ---------------------------------------------------------------------------------- cache


def fingerprint(value: Any, length: int = 10) -> str:
    """A short stable hash of a JSON-able value (a configuration), for cache keys."""
    text = json.dumps(value, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:length]


def cache_file(cache: Path, key: str) -> Path:
    """The file of ``key``: the key made safe, plus a hash of it when that changed the key
    (``a/b`` and ``a_b`` never share a file) or when it is long."""
    name = _SAFE.sub("_", key)
    if name != key or len(name) > 120:
        name = name[:100] + "-" + fingerprint(key)
    return cache / f"{name}.json"


class CacheError(ValueError):
    """A cache entry that must not be used (the message says why)."""


def _canonical(result: Mapping[str, Any]) -> bytes:
    return json.dumps(result, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode()


def checksum(result: Mapping[str, Any]) -> str:
    """The sha256 of a (JSON) result in canonical form: what a cache entry is checked by."""
    return hashlib.sha256(_canonical(result)).hexdigest()


def as_json(result: Mapping[str, Any]) -> Result:
    """``result`` as it reads back from the cache (tuples as lists, other values as text)."""
    data = json.loads(json.dumps(dict(result), default=str))
    return data if isinstance(data, dict) else {}


def read_entry(path: Path, key: str) -> Result:
    """The result stored for ``key`` in ``path`` (with its ``key``); CacheError saying why the
    entry cannot be used."""
    try:
        size = path.stat().st_size
        if size > MAX_ENTRY_BYTES:
            raise CacheError(f"{size} bytes, more than {MAX_ENTRY_BYTES}")
        text = path.read_bytes().decode("utf-8")
        data = json.loads(text)
    except OSError as e:
        raise CacheError(f"cannot read: {e.strerror or e}") from None
    except UnicodeDecodeError as e:
        raise CacheError(f"not UTF-8 (byte {e.start})") from None
    except json.JSONDecodeError as e:
        raise CacheError(f"not JSON: {e.msg} at line {e.lineno} column {e.colno}") from None
    except RecursionError:
        raise CacheError("JSON nested too deeply") from None
    if not isinstance(data, dict):
        raise CacheError("not a JSON object")
    if data.get("schema") != SCHEMA:
        raise CacheError(f"schema {data.get('schema')!r}, expected {SCHEMA}")
    missing = [f for f in ("key", "checksum", "result") if f not in data]
    if missing:
        raise CacheError(f"missing field {missing[0]!r}")
    if data["key"] != key:
        raise CacheError(f"holds key {str(data['key'])[:80]!r}, not {key[:80]!r}")
    result = data["result"]
    if not isinstance(result, dict):
        raise CacheError("its result is not a JSON object")
    if data["checksum"] != checksum(result):
        raise CacheError("checksum mismatch: the result was changed after it was written")
    return {"key": key, **result}


def cached(cache: Path, key: str) -> Result | None:
    """The stored result of ``key``, or None: missing, or bad (then a one-line warning; the
    job is recomputed and its entry rewritten)."""
    path = cache_file(cache, key)
    if not path.exists():
        return None
    try:
        return read_entry(path, key)
    except CacheError as e:
        log.warning("cache entry %s: %s: recomputing it", path, e)
        return None


def store(cache: Path, key: str, result: Mapping[str, Any]) -> Result:
    """Write ``result`` as the entry of ``key`` (atomically) and return it as read back."""
    data = as_json(result)
    entry = {"schema": SCHEMA, "key": key, "checksum": checksum(data), "result": data}
    atomic_write(cache_file(cache, key), json.dumps(entry, indent=1, ensure_ascii=True))
    return {"key": key, **data}


def not_cacheable(result: Mapping[str, Any], reason: str) -> Result:
    """``result`` marked as not to be stored (``reason``: e.g. the planner crashed): this run
    uses it, the next run does the job again."""
    return {**result, NOT_CACHEABLE: reason or "not cacheable"}


# ------------------------------------------------------------------------------- progress


@contextmanager
def progress_bar(
    console: Console | None, description: str, total: int
) -> Iterator[Callable[..., None]]:
    """A rich progress bar with counts per outcome; yields ``advance(outcome="", steps=1)``:
    advance by ``steps`` and count one ``outcome`` (a label, e.g. ``"cached"``)."""
    console = console or Console(stderr=True)
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[counts]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    )
    counts: Counter[str] = Counter()
    with Progress(*columns, console=console, transient=False) as bar:
        task = bar.add_task(description, total=total, counts="")

        def advance(outcome: str = "", steps: int = 1) -> None:
            if outcome:
                counts[outcome] += 1
            text = " · ".join(f"{n} {name}" for name, n in counts.items())
            bar.update(task, advance=steps, counts=text)

        yield advance


# ------------------------------------------------------------------------------------ run


def run_jobs(
    jobs: Sequence[Job[P]],
    work: Callable[[P], Mapping[str, Any]],
    cache: Path,
    *,
    workers: int = 1,
    description: str = "jobs",
    console: Console | None = None,
    executor: ExecutorSpec | Executor | None = None,
) -> list[Result]:
    """Run every job whose result is not cached yet and return all results in job order.

    ``executor``: where the jobs run (default: ``workers`` local processes). ``work`` must be
    a module-level function unless it runs in this process. A job's exception propagates after
    the finished jobs are stored (and Ctrl-C stops the run the same way), so the run can be
    resumed; jobs whose worker was lost on every attempt raise :class:`JobsLost` after all
    the others finished."""
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    keys = [j.key for j in jobs]
    if len(set(keys)) != len(keys):
        dup = sorted({k for k in keys if keys.count(k) > 1})
        raise ValueError(f"duplicate job keys: {', '.join(dup[:5])}")
    if executor is None or isinstance(executor, ExecutorSpec):
        executor = make_executor(executor or ExecutorSpec(), workers)
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
    lost: dict[str, str] = {}
    events = executor.run(todo, work) if todo else iter(())  # a cluster is joined here
    with progress_bar(console, description, len(jobs)) as advance:
        for _ in results:
            advance(Outcome.CACHED.value)
        _collect(events, cache, results, lost, advance)
    if lost:
        first = next(iter(lost.items()))
        raise JobsLost(
            f"{description}: {len(lost)} of {len(jobs)} job(s) lost their worker on every "
            f"attempt (first: {first[0]}: {first[1]}); the others are cached: run again to "
            "retry these"
        )
    return [results[k] for k in keys]


def _collect(
    events: Iterator[Event],
    cache: Path,
    results: dict[str, Result],
    lost: dict[str, str],
    advance: Callable[..., None],
) -> None:
    """Store each finished result as it comes; closing ``events`` on any error (or Ctrl-C)
    stops the executor's jobs still running."""
    try:
        for event in events:
            if event.outcome is Outcome.RETRIED:
                log.warning("%s lost its worker (%s): running it again", event.key, event.detail)
                advance(event.outcome.value, steps=0)
            elif event.outcome is Outcome.LOST:
                log.warning("%s lost its worker on every attempt: %s", event.key, event.detail)
                lost[event.key] = event.detail
                advance(event.outcome.value)
            else:
                result = event.result or {}
                results[event.key] = _keep(cache, event.key, result)
                outcome = Outcome.NOT_CACHED if NOT_CACHEABLE in result else Outcome.RAN
                advance(outcome.value)
    finally:
        close = getattr(events, "close", None)
        if close is not None:
            close()


def _keep(cache: Path, key: str, result: Mapping[str, Any]) -> Result:
    """The result to use: stored, unless it is marked not cacheable."""
    if NOT_CACHEABLE not in result:
        return store(cache, key, result)
    reason = result[NOT_CACHEABLE]
    log.warning("%s: not cached (%s): the next run does it again", key, reason)
    return {"key": key, **as_json({k: v for k, v in result.items() if k != NOT_CACHEABLE})}


__all__ = [
    "EXECUTORS",
    "LLM_RESOURCE",
    "NOT_CACHEABLE",
    "SCHEMA",
    "CacheError",
    "Event",
    "Executor",
    "ExecutorError",
    "ExecutorSpec",
    "Job",
    "JobsLost",
    "LocalExecutor",
    "Outcome",
    "add_executor_arguments",
    "add_llm_argument",
    "backend",
    "cache_file",
    "cached",
    "checksum",
    "executor_from_args",
    "fingerprint",
    "llm_resources",
    "make_executor",
    "not_cacheable",
    "progress_bar",
    "read_entry",
    "run_jobs",
    "store",
]
