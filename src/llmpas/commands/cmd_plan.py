"""``llmpas plan`` (PDDL files or a shipped example) and ``llmpas pddlstream`` (an unchanged
PDDLStream script on llmpas's planner)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from llmpas.commands.cmd_common import (
    CliError,
    add_planner_options,
    planner_config,
    planning_failed,
)
from llmpas.errors import ExitCode, InputError, PlannerError
from llmpas.files import atomic_write
from llmpas.language.language_errors import BindingError
from llmpas.language.problem import Problem, read_problem
from llmpas.limits import time_limit
from llmpas.options import MAX_EXAMPLE_SIZE, bounded_int
from llmpas.planning import PlanResult, PlanStatus, solve


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
    from llmpas.language.domain import read_domain
    from llmpas.language.loading import load_bindings_and_values
    from llmpas.language.streams import read_streams

    domain = read_domain(args.domain)  # the text first: then the user's code
    streams = read_streams(args.streams) if args.streams else None
    bindings, values = load_bindings_and_values(args.bindings) if args.bindings else ({}, {})
    try:
        return read_problem(domain, args.problem, streams, bindings, values=values)
    except BindingError as e:  # the declarations and the implementations do not match
        raise InputError(f"{e} (--bindings {args.bindings})") from None


def _cmd_plan(args: argparse.Namespace, console: Console) -> int:
    problem = _problem_from_args(args)
    config = planner_config(args)
    limit = config.max_time * 1.5 + 10  # a stream implementation may never return
    culprit = f"a stream of --bindings {args.bindings}" if args.bindings else "the planner"
    late = PlannerError(
        f"planning did not end within {limit:g} s (--max-time {config.max_time:g}): "
        f"{culprit} did not return"
    )
    status = f"planning ({config.algorithm}, {config.quality}, defer={config.defer})..."
    with console.status(status), time_limit(limit, late):
        result = solve(problem, config)
    if args.json:
        sys.stdout.write(result.dumps() + "\n")
    else:
        _print_result(result, console, problem.spelling)
    if result.status is PlanStatus.ERROR:
        raise planning_failed(result)
    return 0 if result.solved else 1


def _print_result(
    result: PlanResult, console: Console, written: Mapping[str, str] | None = None
) -> None:
    """The plan, objects named as the problem file writes them, and the statistics."""
    written = written or {}
    s = result.stats
    if result.plan is None:
        console.print(f"[bold red]{result.status.value}[/]: {result.message}")
    else:
        console.print(
            f"[bold green]solved[/]: {len(result.plan)} actions, cost {result.plan.cost:g}, "
            f"{s.total_time:.2f} s" + (f" ({result.message})" if result.message else ""),
            highlight=False,
        )
        for i, step in enumerate(result.plan.steps, 1):
            deferred = (
                "  [dim]defers " + ", ".join(map(str, step.deferred)) + "[/]"
                if step.deferred
                else ""
            )
            text = " ".join([step.action, *(written.get(a, a) for a in step.args)])
            console.print(f"  {i:3d}. ({text}){deferred}", highlight=False)
    table = Table(title="statistics", show_header=False)
    table.add_row("algorithm", f"{s.algorithm}, quality {s.quality}")
    table.add_row("plan cost", "—" if result.plan is None else f"{result.plan.cost:g}")
    if len(result.improvements) > 1:
        table.add_row(
            "cheaper plans (cost @ s)",
            ", ".join(f"{i.cost:g} @ {i.time:.2f}" for i in result.improvements),
        )
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


def add_plan(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("plan", help="plan for PDDL files or a shipped example")
    p.add_argument("domain", nargs="?", help="domain.pddl")
    p.add_argument("problem", nargs="?", help="problem.pddl")
    p.add_argument("--streams", help="stream.pddl")
    p.add_argument("--bindings", help="MODULE:NAME of a mapping stream name -> implementation")
    p.add_argument("--example", help="a shipped example (see 'llmpas examples')")
    p.add_argument(
        "--size", type=bounded_int(1, MAX_EXAMPLE_SIZE), help="size of the example (objects/blocks)"
    )
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    add_planner_options(p)
    p.set_defaults(handler=_cmd_plan)


def _cmd_pddlstream(args: argparse.Namespace, console: Console) -> int:
    from llmpas.pddlstream.runner import run_script

    run = run_script(args.script, args.args, validate_plans=not args.no_validate, seed=args.seed)
    for i, c in enumerate(run.checked, 1):
        r, v = c.attempt.result, c.validation
        if r.plan is None:
            what = f"[red]{r.status.value}[/]: {escape(r.message)}"
        else:
            valid = "[green]valid[/]" if v.valid else f"[red]invalid[/]: {escape(v.message)}"
            what = (
                f"[green]solved[/]: {len(r.plan)} actions, cost {c.attempt.solution.cost:g}; "
                f"replay: {valid}"
            )
        console.print(
            f"[bold]llmpas pddlstream[/] solve #{i}: {what}; {c.attempt.cpu_seconds:.2f} s CPU",
            highlight=False,
        )
    if args.summary:
        summary = {
            "script": args.script,
            "args": list(args.args),
            "exit_code": run.exit_code,
            "error": run.error,
            "solves": [
                {
                    "status": c.attempt.result.status.value,
                    "length": None if c.attempt.result.plan is None else len(c.attempt.result.plan),
                    "cost": c.attempt.solution.cost if c.attempt.result.solved else None,
                    "valid": c.validation.valid,
                    "validation": c.validation.message,
                    "cpu_seconds": c.attempt.cpu_seconds,
                }
                for c in run.checked
            ],
        }
        atomic_write(Path(args.summary), json.dumps(summary, indent=2) + "\n")
    if run.error:
        raise CliError(
            run.error,
            ExitCode(run.exit_code) if run.exit_code in set(ExitCode) else ExitCode.FAILED,
        )
    return run.exit_code


def add_pddlstream(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "pddlstream",
        help="run an unchanged PDDLStream script on llmpas's planner (docs/pddlstream.md)",
    )
    p.add_argument("script", help="the script (.py)")
    p.add_argument("args", nargs=argparse.REMAINDER, help="the script's own arguments")
    p.add_argument("--no-validate", action="store_true", help="do not replay the plans")
    p.add_argument("--summary", help="write what each solve call did to this JSON file")
    p.add_argument(
        "--seed", type=int, help="seed Python's and numpy's global random generators first"
    )
    p.set_defaults(handler=_cmd_pddlstream)


__all__ = ["add_pddlstream", "add_plan"]
