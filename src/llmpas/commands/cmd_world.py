"""``llmpas execute``, ``llmpas bt`` and ``llmpas robot``: a registered world's scenario planned
and executed once, its behaviour subtrees, its simulated robot (the worlds by name from
:mod:`llmpas.system.catalog`); and the parts ``llmpas run`` shares with them."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape

from llmpas.commands.cmd_common import (
    CliError,
    add_planner_options,
    planner_config,
    planning_failed,
)
from llmpas.errors import InputError, UsageError
from llmpas.files import atomic_write
from llmpas.language.language_errors import LanguageError


def world_name(args: argparse.Namespace) -> str:
    """``--world``, else the registered world that ships the scenario (a file: household)."""
    from llmpas.system.catalog import world_of

    if args.world:
        return str(args.world)
    try:
        return world_of(args.scenario)
    except UsageError as e:  # an unknown scenario name
        raise CliError(str(e)) from None


@contextmanager
def naming(scenario: str) -> Iterator[None]:
    """Problem-language errors raised while the problem of a scenario file is built (its goal
    names an unknown predicate, say) name the file."""
    try:
        yield
    except LanguageError as e:
        if str(e).startswith(scenario):
            raise
        raise InputError(f"{scenario}: task.goal: {e}") from None


def run_options(args: argparse.Namespace) -> Any:
    from llmpas.worlds.api import RunOptions

    return RunOptions(
        planner=planner_config(args),
        seed=args.seed,
        gui=bool(getattr(args, "gui", False)),
        robot_profile=getattr(args, "robot_profile", None),
        site=getattr(args, "site", None),
    )


@contextmanager
def _recorded(out: str | None) -> Iterator[Any]:
    """``OUT/run.mcap`` (the Foxglove channels) for a command's ``--out`` (None: no folder)."""
    if not out:
        yield None
        return
    from llmpas.reporting.live import FoxgloveSink

    with FoxgloveSink(Path(out) / "run.mcap") as sink:
        yield sink


def _cmd_execute(args: argparse.Namespace, console: Console) -> int:
    from llmpas.system import run_once
    from llmpas.system.catalog import load_world, scenario_arg

    name = world_name(args)
    world = load_world(name)
    scenario = scenario_arg(name, args.scenario)
    with (
        console.status(f"planning and executing {args.scenario} ..."),
        naming(scenario),
        _recorded(args.out) as observer,
    ):
        result = run_once(world, scenario, run_options(args), args.out, observer)
    rnd = result.rounds[0]
    ep = rnd.episode
    if ep is None:
        raise planning_failed(rnd.plan)
    steps = rnd.plan.plan.steps if rnd.plan.plan else ()
    if args.out:
        console.print(f"wrote the episode folder {args.out}")
        plan_time = rnd.plan.stats.total_time
        shown = [str(s) for s in steps]
        web_report(args, console, world=world.title, task=rnd.goal, plan=shown, plan_time=plan_time)
    if args.json:
        sys.stdout.write(json.dumps(ep.to_json(), indent=2) + "\n")
        return 0 if result.success else 1
    console.print(
        f"plan: {len(steps)} actions in {len(rnd.specs)} subtrees, "
        f"planned in {rnd.plan.stats.total_time:.2f} s"
    )
    for label in ep.subtrees:
        console.print(f"  - {label}", highlight=False, markup=False)
    if ep.succeeded and result.success:
        console.print(f"[bold green]success[/] ({ep.retries} retries, {ep.ticks} ticks)")
        return 0
    if ep.anomaly is not None:
        console.print("[bold yellow]anomaly[/]: " + escape(ep.anomaly.describe()), highlight=False)
        return 1
    belief_and_truth(result, console)
    console.print(f"[bold red]{ep.status.value}[/]: {escape(ep.message or result.message)}")
    return 1


def _cmd_bt(args: argparse.Namespace, console: Console) -> int:
    from llmpas.execution.export import render_png, to_ascii, to_btcpp_files
    from llmpas.system import plan
    from llmpas.system.catalog import load_world, scenario_arg
    from llmpas.worlds.api import RunOptions

    name = world_name(args)
    scenario = scenario_arg(name, args.scenario)
    options = RunOptions(planner=planner_config(args), seed=args.seed)
    with naming(scenario), load_world(name).open(scenario, options) as session:
        result, problem = plan(session, session.task, 0)
        if result.plan is None:
            raise planning_failed(result)
        specs = list(session.decompose(problem, result.plan))
    if args.bt == "show":
        for spec in specs:
            console.print(to_ascii(spec), highlight=False, markup=False)
        if args.png:
            out = Path(args.png)
            out.mkdir(parents=True, exist_ok=True)
            for i, spec in enumerate(specs):
                render_png(spec, out / f"csubbt{i}.png")
            console.print(f"wrote {len(specs)} PNG files to {out}")
        return 0
    out = Path(args.out)
    for file, text in to_btcpp_files(specs).items():
        atomic_write(out / file, text)
    console.print(f"wrote BehaviorTree.CPP v4 XML of {len(specs)} subtrees to {out}")
    return 0


def add_world_option(p: argparse.ArgumentParser) -> None:
    """``--world``: the registered worlds that name themselves in the help
    (:func:`llmpas.system.catalog.world_help`), or a user's."""
    from llmpas.system.catalog import file_world, world_help

    reader = file_world()
    p.add_argument(
        "--world",
        help=f"{world_help()}, or your own package.module:WORLD "
        "(default: the world that ships the scenario; a .toml file: "
        f"{reader.name if reader else 'none'})",
    )


def add_execute(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    scenario_help = "a shipped scenario name (e.g. object-loss-table) or a household .toml"
    p = sub.add_parser("execute", help="plan and execute a scenario once (no LLM)")
    p.add_argument("scenario", help=scenario_help)
    p.add_argument("--out", help="run folder: loop.json, round-0/ (episode, reports, CSubBT XML)")
    p.add_argument("--json", action="store_true", help="print the episode as JSON")
    p.add_argument("--gui", action="store_true", help="open the simulator window (PyBullet)")
    add_world_option(p)
    add_planner_options(p)
    p.set_defaults(handler=_cmd_execute, seed=None)
    bt = sub.add_parser("bt", help="the conditional behaviour subtrees of a scenario's plan")
    bsub = bt.add_subparsers(dest="bt", required=True)
    exp = bsub.add_parser("export", help="write BehaviorTree.CPP v4 XML")
    exp.add_argument("scenario", help=scenario_help)
    exp.add_argument("--out", default="bt")
    add_world_option(exp)
    add_planner_options(exp)
    exp.set_defaults(handler=_cmd_bt)
    show = bsub.add_parser("show", help="print the subtrees (and render PNGs with --png DIR)")
    show.add_argument("scenario", help=scenario_help)
    show.add_argument("--png", help="folder for one PNG per subtree (needs graphviz)")
    add_world_option(show)
    add_planner_options(show)
    show.set_defaults(handler=_cmd_bt)


def belief_and_truth(result: Any, console: Console) -> None:
    """A line when the robot's belief and the world's truth disagree (a lookalike carried)."""
    if result.truth is not None and result.believed != result.truth:
        console.print(f"[bold yellow]belief and truth differ[/]: {result.verdicts}")


def web_report(args: argparse.Namespace, console: Console, **about: Any) -> None:
    """``index.html`` in the ``--out`` folder (llmpas.reporting)."""
    from llmpas.reporting.report_command import after_run

    after_run(args, lambda s: console.print(s, highlight=False), **about)


def _cmd_robot(args: argparse.Namespace, console: Console) -> int:
    """Serve a simulated robot: the command of the world that owns it (its own parser)."""
    from llmpas.system.catalog import robot_command

    return robot_command(args.kind)(args.args)


def add_robot(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "robot",
        help="serve a simulated robot over ROS 2 for --world ros2 (docs/ros.md); "
        "llmpas robot pybullet --help for its options",
    )
    p.add_argument("kind", help="the simulated robot: pybullet")
    p.add_argument("args", nargs=argparse.REMAINDER, help="the robot's own options")
    p.set_defaults(handler=_cmd_robot)


__all__ = [
    "add_execute",
    "add_robot",
    "add_world_option",
    "belief_and_truth",
    "naming",
    "run_options",
    "web_report",
    "world_name",
]
