"""One benchmark harness: what every ``llmpas bench NAME`` shares, in one place.

A benchmark declares only its own concern (:class:`Harnessed`):

- its **options** (``arguments``) and its **config** built from them and the shared settings
  (``config``: the parsed options and a :class:`Shared`);
- its **run** (``run``: the config and a console; the files written): its trials are jobs of
  :mod:`llmpas.experiments.jobs`, run by :func:`run_trials` and read back as rows by
  :func:`rows_of`; its table is written by its own module;
- which **shared options** it takes (:class:`SharedOptions`: ``--jobs`` and its help, ``--out``
  and its default, the executor's ``--executor``/``--ray-address``) and its step in
  ``llmpas bench all`` (``in_all``).

The harness adds the shared options (:func:`add_shared_arguments`), reads them back
(:func:`shared_from_args`), runs the trials with the cache under ``OUT/cache`` (so a run resumes),
on ``--jobs`` local processes or a Ray cluster (:func:`run_trials`), turns each cached result
into its row (:func:`rows_of`) and says which files were written.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

from rich.console import Console

from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    Result,
    add_executor_arguments,
    executor_from_args,
    run_jobs,
)

C = TypeVar("C")
P = TypeVar("P")
R = TypeVar("R")
CACHE = "cache"  # the folder under --out holding the trials' results


@dataclass(frozen=True)
class SharedOptions:
    """The shared options a benchmark takes, with their defaults and help.

    ``out``: the default ``--out`` (None: no ``--out``); ``jobs``: whether it takes ``--jobs``
    (``jobs_help``: its help; ``jobs_type``: how it is read); ``executor``: whether it takes
    ``--executor`` and ``--ray-address``; ``out_type``: how ``--out`` is read."""

    out: str | None = None
    out_help: str | None = None
    jobs: bool = True
    jobs_help: str | None = None
    jobs_type: Callable[[str], int] = int
    executor: bool = True
    out_type: Callable[[str], Any] = str


@dataclass(frozen=True)
class Shared:
    """The shared settings of one run: where it writes (and caches), how many local processes,
    which executor."""

    out_dir: Path = Path("results")
    jobs: int = 1
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)


def add_shared_arguments(p: argparse.ArgumentParser, options: SharedOptions) -> None:
    """``--jobs``, ``--out``, ``--executor`` and ``--ray-address``, as ``options`` says."""
    if options.jobs:
        p.add_argument("--jobs", type=options.jobs_type, default=1, help=options.jobs_help)
    if options.out is not None:
        default = options.out_type(options.out)
        p.add_argument("--out", type=options.out_type, default=default, help=options.out_help)
    if options.executor:
        add_executor_arguments(p)


def shared_from_args(args: argparse.Namespace) -> Shared:
    """The shared settings of parsed options (a missing option: its default)."""
    out = getattr(args, "out", None)
    return Shared(
        out_dir=Path(out) if out is not None else Shared.out_dir,
        jobs=getattr(args, "jobs", 1),
        executor=executor_from_args(args),
    )


class Runs(Protocol):
    """A benchmark's config as the harness reads it: where it writes, how it runs."""

    @property
    def out_dir(self) -> Path: ...

    @property
    def jobs(self) -> int: ...

    @property
    def executor(self) -> ExecutorSpec: ...


def run_trials(
    config: Runs,
    jobs: Sequence[Job[P]],
    trial: Callable[[P], Mapping[str, Any]],
    description: str,
    console: Console | None = None,
    cache: str = CACHE,
) -> list[Result]:
    """Every trial's result, in job order: cached under ``OUT/cache`` (or ``OUT/<cache>``; an
    interrupted run resumes), run on the config's executor (``jobs`` local processes, or Ray)."""
    return run_jobs(
        jobs,
        trial,
        config.out_dir / cache,
        workers=config.jobs,
        description=description,
        console=console,
        executor=config.executor,
    )


def rows_of(kind: type[R], results: Iterable[Mapping[str, Any]]) -> list[R]:
    """Each result as the frozen dataclass ``kind`` (its fields only: the cache's ``key`` and
    any extra field are left out)."""
    names = {f.name for f in fields(kind)}  # type: ignore[arg-type]
    return [kind(**{k: v for k, v in r.items() if k in names}) for r in results]


def wrote(console: Console, files: Iterable[Path]) -> None:
    """The line every benchmark ends with: the files it wrote."""
    console.print(f"wrote {', '.join(str(p) for p in files)}")


@dataclass(frozen=True)
class Harnessed(Generic[C]):
    """A :class:`~llmpas.experiments.benchmarks.Benchmark` declared by its concern only: its
    options, its config, its run (the files it wrote; None: it said so itself), which shared
    options it takes and its step in ``bench all`` (None: not a step)."""

    name: str
    help: str
    arguments: Callable[[argparse.ArgumentParser], None]
    config: Callable[[argparse.Namespace, Shared], C]
    run: Callable[[C, Console], Sequence[Path] | None]
    shared: SharedOptions = field(default_factory=SharedOptions)
    in_all: Callable[[AllConfig], tuple[str, ...] | None] | None = None

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        self.arguments(parser)
        add_shared_arguments(parser, self.shared)

    def command(self, args: argparse.Namespace, console: Console) -> int:
        files = self.run(self.config(args, shared_from_args(args)), console)
        if files is not None:
            wrote(console, files)
        return 0

    def step(self, config: AllConfig) -> tuple[str, ...] | None:
        return None if self.in_all is None else self.in_all(config)


__all__ = [
    "CACHE",
    "Harnessed",
    "Runs",
    "Shared",
    "SharedOptions",
    "add_shared_arguments",
    "rows_of",
    "run_trials",
    "shared_from_args",
    "wrote",
]
