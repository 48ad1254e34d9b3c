"""The ``llmpas`` command line."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import logging
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.logging import RichHandler
from rich.table import Table

from llmpas.language.errors import LanguageError
from llmpas.language.problem import Problem, read_problem
from llmpas.planning import PlannerConfig, PlanResult, solve

Handler = Callable[[argparse.Namespace, Console], int]


class CliError(Exception):
    """A user error: printed as one line, exit status 2."""


# ------------------------------------------------------------------------------------- plan


def _add_planner_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--algorithm", choices=("focused", "incremental"), default="focused")
    p.add_argument(
        "--defer",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="leave deferred streams (e.g. BaseMotion, Kin) to execution",
    )
    p.add_argument("--max-time", type=float, default=60.0, help="seconds for the whole plan")
    p.add_argument("--seed", type=int, default=0)


def _planner_config(args: argparse.Namespace) -> PlannerConfig:
    try:
        return PlannerConfig(
            algorithm=args.algorithm,
            defer=args.defer,
            max_time=args.max_time,
            search_time=args.max_time,
            seed=args.seed,
        )
    except ValueError as e:
        raise CliError(str(e)) from None


def _load_bindings(spec: str | None) -> Mapping[str, Any]:
    """``MODULE:NAME`` or ``path/to/file.py:NAME`` -> the mapping stream name -> implementation."""
    if spec is None:
        return {}
    where, _, attr = spec.rpartition(":")
    if not where or not attr:
        raise CliError(f"--bindings {spec!r}: expected MODULE:NAME or FILE.py:NAME")
    try:
        module = _import(where)
        obj = getattr(module, attr)
    except (ImportError, AttributeError, OSError) as e:
        raise CliError(f"--bindings {spec!r}: {e}") from None
    try:
        value = obj if isinstance(obj, Mapping) or not callable(obj) else obj()
    except TypeError as e:
        raise CliError(f"--bindings {spec!r}: calling it failed: {e}") from None
    if not isinstance(value, Mapping):
        raise CliError(f"--bindings {spec!r} is {type(value).__name__}, not a mapping")
    return value


def _import(where: str) -> Any:
    if not where.endswith(".py"):
        return importlib.import_module(where)
    path = Path(where)
    if not path.is_file():
        raise ImportError(f"{where}: no such file")
    spec = importlib.util.spec_from_file_location(f"llmpas_bindings_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{where}: cannot be imported")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _problem_from_args(args: argparse.Namespace) -> Problem:
    if args.example:
        from llmpas.examples import get_example

        try:
            ex = get_example(args.example)
        except KeyError as e:
            raise CliError(str(e.args[0])) from None
        return ex.make_problem(args.size or ex.default_size, args.seed)
    if not args.domain or not args.problem:
        raise CliError("give DOMAIN and PROBLEM files, or --example NAME")
    for f in (args.domain, args.problem, args.streams):
        if f is not None and not Path(f).is_file():
            raise CliError(f"{f}: no such file")
    return read_problem(args.domain, args.problem, args.streams, _load_bindings(args.bindings))


def _cmd_plan(args: argparse.Namespace, console: Console) -> int:
    problem = _problem_from_args(args)
    config = _planner_config(args)
    with console.status(f"planning ({config.algorithm}, defer={config.defer})..."):
        result = solve(problem, config)
    if args.json:
        sys.stdout.write(result.dumps() + "\n")
    else:
        _print_result(result, console)
    return 0 if result.solved else 1


def _print_result(result: PlanResult, console: Console) -> None:
    s = result.stats
    if result.plan is None:
        console.print(f"[bold red]{result.status.value}[/]: {result.message}")
    else:
        console.print(
            f"[bold green]solved[/]: {len(result.plan)} actions, cost {result.plan.cost:g}"
        )
        for i, step in enumerate(result.plan.steps, 1):
            deferred = (
                "  [dim]defers " + ", ".join(map(str, step.deferred)) + "[/]"
                if step.deferred
                else ""
            )
            console.print(f"  {i:3d}. {step}{deferred}")
    table = Table(title="statistics", show_header=False)
    table.add_row("algorithm", s.algorithm)
    table.add_row("iterations", str(s.iterations))
    table.add_row(
        "stream calls", ", ".join(f"{k}={v}" for k, v in sorted(s.stream_calls.items())) or "0"
    )
    table.add_row(
        "time: streams / translate / search / total",
        f"{s.stream_time:.3f} / {s.translate_time:.3f} / {s.search_time:.3f} / "
        f"{s.total_time:.3f} s",
    )
    console.print(table)


def _add_plan(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("plan", help="plan for PDDL files or a shipped example")
    p.add_argument("domain", nargs="?", help="domain.pddl")
    p.add_argument("problem", nargs="?", help="problem.pddl")
    p.add_argument("--streams", help="stream.pddl")
    p.add_argument("--bindings", help="MODULE:NAME of a mapping stream name -> implementation")
    p.add_argument("--example", help="a shipped example (see 'llmpas examples')")
    p.add_argument("--size", type=int, help="size of the example (objects/blocks)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    _add_planner_options(p)
    p.set_defaults(handler=_cmd_plan)


def _cmd_examples(args: argparse.Namespace, console: Console) -> int:
    from llmpas.examples import EXAMPLES

    table = Table("name", "default size", "description")
    for ex in EXAMPLES.values():
        table.add_row(ex.name, str(ex.default_size), ex.description)
    console.print(table)
    return 0


# ------------------------------------------------------------------------------------- bench


def _cmd_bench_planning_time(args: argparse.Namespace, console: Console) -> int:
    from llmpas.experiments.planning_time import BenchConfig, run_planning_time

    try:
        config = BenchConfig(
            examples=tuple(args.examples),
            trials=args.trials,
            max_time=args.max_time,
            sizes=tuple(args.sizes) if args.sizes else None,
            out_dir=Path(args.out),
        )
    except ValueError as e:
        raise CliError(str(e)) from None
    report = run_planning_time(config, console)
    console.print(f"wrote {', '.join(str(p) for p in report.files)}")
    return 0


def _add_bench(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("bench", help="benchmarks and experiments")
    bsub = p.add_subparsers(dest="bench", required=True)
    pt = bsub.add_parser("planning-time", help="initial planning time vs size, deferred vs eager")
    pt.add_argument("--examples", nargs="+", default=["mobile", "tamp2d"])
    pt.add_argument("--sizes", nargs="+", type=int, help="override the example's sizes")
    pt.add_argument("--trials", type=int, default=5)
    pt.add_argument("--max-time", type=float, default=60.0, help="seconds per planning run")
    pt.add_argument("--out", default="results/planning-time")
    pt.set_defaults(handler=_cmd_bench_planning_time)


# -------------------------------------------------------------------------------------- main


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="llmpas", description=__doc__)
    parser.add_argument("-v", "--verbose", action="count", default=0)
    sub = parser.add_subparsers(dest="command", required=True)
    _add_plan(sub)
    ex = sub.add_parser("examples", help="list the shipped example problems")
    ex.set_defaults(handler=_cmd_examples)
    _add_bench(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    console = Console(stderr=False)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(
        level=level, format="%(message)s", handlers=[RichHandler(console=Console(stderr=True))]
    )
    handler: Handler = args.handler
    try:
        return handler(args, console)
    except (CliError, LanguageError) as e:
        Console(stderr=True).print(f"[bold red]error:[/] {e}", highlight=False, soft_wrap=True)
        return 2


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["main"]
