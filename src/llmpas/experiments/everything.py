"""``llmpas bench all``: every experiment with one LLM backend, one after another.

Each step is exactly one of the ``llmpas bench ...`` commands (the same options, the same cached
and resumable results), run with its output folder under ``--out``. A step that fails does not
stop the others; ``summary.md`` lists every step with its command, outcome, time and files, and
the exit status is 1 when any step failed.

``--quick`` runs every experiment on a small slice (a smoke test of the whole pipeline, minutes
with ``--llm oracle``); its numbers are not the published ones.
"""

from __future__ import annotations

import argparse
import shlex
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console

from llmpas.experiments.benchmarks import ORACLE, AllConfig, benchmarks
from llmpas.experiments.harness import SharedOptions, add_shared_arguments, shared_from_args
from llmpas.experiments.jobs import add_llm_argument
from llmpas.files import atomic_write

QUICK_TASKS = ("ol01-table2", "ab06-sink-mug", "sc06-apple-frozen-stove")


@dataclass(frozen=True)
class Step:
    """One experiment: its name (also its output folder) and its ``llmpas`` arguments."""

    name: str
    argv: tuple[str, ...]

    def __post_init__(self) -> None:
        if not self.name or "/" in self.name:
            raise ValueError(f"a step name must be a plain folder name, got {self.name!r}")
        if self.argv[:1] != ("bench",):
            raise ValueError(f"a step runs an `llmpas bench` command, got {self.argv!r}")

    @property
    def command(self) -> str:
        return shlex.join(("llmpas", *self.argv))


def plan_steps(config: AllConfig) -> tuple[Step, ...]:
    """The experiments in the order they run (the registry's, :data:`~llmpas.experiments.
    benchmarks.BENCHMARKS`): each registered benchmark whose :meth:`~llmpas.experiments.
    benchmarks.Benchmark.step` gives options for ``config``."""
    steps = []
    for bench in benchmarks():
        options = bench.step(config)
        if options is not None:
            steps.append(Step(bench.name, ("bench", bench.name, *options)))
    return tuple(steps)


@dataclass(frozen=True)
class Outcome:
    step: Step
    status: int  # the command's exit status (0: it worked)
    seconds: float
    files: tuple[Path, ...]


Runner = Callable[[Sequence[str]], int]  # llmpas.cli.main


def run_all(config: AllConfig, run: Runner, console: Console | None = None) -> list[Outcome]:
    """Run every step with ``run`` (the CLI's ``main``) and write ``summary.md``."""
    console = console or Console()
    outcomes = []
    steps = plan_steps(config)
    for i, step in enumerate(steps, 1):
        console.rule(f"[bold]{i}/{len(steps)} {step.name}[/]: {step.command}")
        start = time.perf_counter()
        try:
            status = run(step.argv)
        except Exception as e:  # a crashed step is reported; the rest still run
            console.print(f"[bold red]{step.name} failed:[/] {type(e).__name__}: {e}")
            status = 1
        folder = config.out_dir / step.name
        files = tuple(sorted(folder.glob("*.md"))) + tuple(sorted(folder.glob("*.png")))
        outcomes.append(Outcome(step, status, time.perf_counter() - start, files))
    summary = config.out_dir / "summary.md"
    config.out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write(summary, summary_markdown(config, outcomes))
    console.print(f"wrote {summary}")
    return outcomes


def summary_markdown(config: AllConfig, outcomes: Sequence[Outcome]) -> str:
    lines = [
        "# llmpas: every experiment",
        "",
        f"LLM: `{config.llm}`"
        + (" (quick slice: not the published numbers)" if config.quick else ""),
        "",
        "| experiment | outcome | time | files | command |",
        "|---|---|---:|---|---|",
    ]
    for o in outcomes:
        links = ", ".join(
            f"[{p.name}]({p.relative_to(config.out_dir).as_posix()})" for p in o.files
        )
        outcome = "ok" if o.status == 0 else f"failed (exit {o.status})"
        lines.append(
            f"| {o.step.name} | {outcome} | {o.seconds:.0f} s | {links or '-'} | "
            f"`{o.step.command}` |"
        )
    total = sum(o.seconds for o in outcomes)
    lines += ["", f"Total: {total / 60:.1f} min.", ""]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------ CLI


SHARED = SharedOptions(
    out="results",
    out_help="one folder per experiment under this",
    jobs_help="parallel processes per experiment",
)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench all``."""
    add_llm_argument(p)
    p.add_argument("--samples", type=int, default=3, help="prompting: samples per task")
    p.add_argument("--count", type=int, default=20, help="blocks world: instances per size")
    p.add_argument("--quick", action="store_true", help="a small slice of every experiment")
    add_shared_arguments(p, SHARED)


def command(args: argparse.Namespace, console: Console, run: Runner) -> int:
    shared = shared_from_args(args)
    config = AllConfig(
        llm=args.llm,
        jobs=shared.jobs,
        samples=args.samples,
        count=args.count,
        quick=args.quick,
        out_dir=shared.out_dir,
        executor=shared.executor,
    )
    if config.executor.kind == "ray":  # one line now, not one failure per step
        from llmpas.experiments.cluster import import_ray

        import_ray()
    outcomes = run_all(config, run, console)
    failed = [o.step.name for o in outcomes if o.status != 0]
    if failed:
        console.print(f"[bold red]failed:[/] {', '.join(failed)}")
    return 1 if failed else 0


__all__ = [
    "ORACLE",
    "QUICK_TASKS",
    "AllConfig",
    "Outcome",
    "Step",
    "add_arguments",
    "command",
    "plan_steps",
    "run_all",
]
