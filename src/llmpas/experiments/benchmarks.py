"""Benchmarks as a registry: every ``llmpas bench NAME`` command is a :class:`Benchmark`.

A benchmark has a name (its subcommand and, in ``bench all``, its output folder), a one-line
help, its options (:meth:`Benchmark.add_arguments`), its command (:meth:`Benchmark.command`, an
exit status) and its step in ``llmpas bench all`` (:meth:`Benchmark.step`: its options for
:class:`AllConfig`, or None when ``bench all`` leaves it out).

:data:`BENCHMARKS` maps each name to ``"module:attribute"``, the object implementing the protocol;
the module is imported the first time it is needed (:func:`benchmark`). The command line builds
one subcommand per entry, and ``bench all`` runs the entries' steps in the registry's order: a new
benchmark is one new module and one line here.

A benchmark with trials is a :class:`~llmpas.experiments.harness.Harnessed`: it declares its own
options, its config, its run and which shared options it takes; the harness adds ``--jobs``,
``--out`` and the executor's options, runs the trials cached under ``OUT/cache`` (resumable, on
local processes or Ray) and reads them back as rows. :class:`Bench` is for the commands without
trials of their own (``validate-data``, ``report``, ``ros``, ``live``).
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Protocol, runtime_checkable

from rich.console import Console

from llmpas.experiments.jobs import ExecutorSpec
from llmpas.reasoning.backends.backend_registry import BACKENDS, choices
from llmpas.reasoning.truth_oracle import ORACLE

#: The benchmarks, in the order ``llmpas bench all`` runs them: data check, planner, executor,
#: reasoner, then what ``bench all`` leaves out.
BENCHMARKS: Mapping[str, str] = MappingProxyType(
    {
        "validate-data": "llmpas.experiments.suite.validate_data:BENCHMARK",
        "planning-time": "llmpas.experiments.planning_time:BENCHMARK",
        "tamp": "llmpas.experiments.tamp_bench:BENCHMARK",
        "pddlstream": "llmpas.experiments.pddlstream_bench:BENCHMARK",
        "perturbation": "llmpas.experiments.perturbation:BENCHMARK",
        "prompting": "llmpas.experiments.prompting:BENCHMARK",
        "recovery": "llmpas.experiments.recovery_bench:BENCHMARK",
        "knowledge": "llmpas.experiments.knowledge:BENCHMARK",
        "blocksworld": "llmpas.experiments.blocksworld:BENCHMARK",
        "llm": "llmpas.experiments.llm_bench:BENCHMARK",
        "report": "llmpas.experiments.webreport:BENCHMARK",
        "ros": "llmpas.experiments.ros_overhead:BENCHMARK",
        "live": "llmpas.experiments.live_overhead:BENCHMARK",
    }
)


@dataclass(frozen=True)
class AllConfig:
    """The settings of ``llmpas bench all`` that the steps share."""

    llm: str = "llama-cpp"
    jobs: int = 1
    samples: int = 3  # prompting: samples per task and method
    count: int = 20  # blocks world: instances per size
    quick: bool = False
    out_dir: Path = Path("results")
    # every step but validate-data runs there
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)

    def __post_init__(self) -> None:
        if not self.llm:
            raise ValueError(f"llm must name a backend ({choices(('oracle', *BACKENDS))})")
        for name in ("jobs", "samples", "count"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")

    def jobs_argv(self) -> tuple[str, ...]:
        return ("--jobs", str(self.jobs))

    def outputs(self, name: str) -> tuple[str, ...]:
        """``--out`` (the step's folder under ``out_dir``) and the executor's options."""
        return ("--out", str(self.out_dir / name), *self.executor.argv())


@runtime_checkable
class Benchmark(Protocol):
    """One ``llmpas bench NAME`` command."""

    @property
    def name(self) -> str: ...

    @property
    def help(self) -> str: ...

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Its options."""

    def command(self, args: argparse.Namespace, console: Console) -> int:
        """Run it; the exit status (a ``ValueError`` is a one-line usage error)."""

    def step(self, config: AllConfig) -> tuple[str, ...] | None:
        """Its options as a step of ``llmpas bench all`` (None: not a step)."""


@dataclass(frozen=True)
class Bench:
    """A :class:`Benchmark` made of its module's functions."""

    name: str
    help: str
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace, Console], int]
    in_all: Callable[[AllConfig], tuple[str, ...] | None] | None = None  # None: not a step

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        self.arguments(parser)

    def command(self, args: argparse.Namespace, console: Console) -> int:
        return self.run(args, console)

    def step(self, config: AllConfig) -> tuple[str, ...] | None:
        return None if self.in_all is None else self.in_all(config)


def benchmark_names() -> tuple[str, ...]:
    """The registered benchmarks, in ``bench all``'s order."""
    return tuple(BENCHMARKS)


def benchmark(name: str) -> Benchmark:
    """The registered benchmark ``name`` (its module imported now); ``ValueError`` naming the
    choices when there is none, ``TypeError`` when the entry is not a :class:`Benchmark`."""
    try:
        target = BENCHMARKS[name]
    except KeyError:
        raise ValueError(
            f"unknown benchmark {name!r}; choose one of {', '.join(BENCHMARKS)}"
        ) from None
    module, attribute = target.split(":")
    found = getattr(importlib.import_module(module), attribute)
    if not isinstance(found, Benchmark) or found.name != name:
        raise TypeError(f"benchmark {name!r}: {target} is not a Benchmark named {name!r}")
    return found


def benchmarks() -> tuple[Benchmark, ...]:
    """Every registered benchmark, in ``bench all``'s order."""
    return tuple(benchmark(n) for n in BENCHMARKS)


__all__ = [
    "BENCHMARKS",
    "ORACLE",
    "AllConfig",
    "Bench",
    "Benchmark",
    "benchmark",
    "benchmark_names",
    "benchmarks",
]
