"""``llmpas run``: the closed loop on a registered world's scenario with an ``--llm`` of the
product's registry (:mod:`llmpas.system.catalog`). It imports nothing from
:mod:`llmpas.experiments` (an import-linter contract): a judged task file (a household scenario
with a ``[judge]`` table) is read by its world (the registration's ``tasks`` hook)."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape

from llmpas.commands.cmd_common import CliError, add_planner_options
from llmpas.commands.cmd_world import (
    add_world_option,
    belief_and_truth,
    naming,
    run_options,
    web_report,
    world_name,
)
from llmpas.errors import ExitCode, InputError, LlmpasError
from llmpas.options import positive_float, positive_int
from llmpas.safetext import printable


def _llm(spec: str, record: str | None, world: str | None = None, method: str = "flp") -> Any:
    """The loop's LLM for a spec of any kind of the backend registry
    (:data:`llmpas.reasoning.backends.backend_registry.KINDS`)."""
    from llmpas.system.catalog import llm_for

    try:
        return llm_for(spec, record, world, method)
    except LlmpasError:
        raise
    except ValueError as e:
        raise CliError(f"--llm {e}") from None


def _cmd_run(args: argparse.Namespace, console: Console) -> int:
    from llmpas.reasoning.assists import parse_assists
    from llmpas.reasoning.llm import LLMError
    from llmpas.reasoning.methods import MethodConfig
    from llmpas.system import LoopSettings, run, run_once
    from llmpas.system.catalog import load_world, scenario_arg, site_world

    _live_address(args)  # a bad --live is one line before anything is loaded
    site = getattr(args, "site", None)
    reader = site_world()
    sites = reader.name if reader else ""  # the world that reads a site: a ROS 2 robot's
    name = sites if site and not args.world else world_name(args)
    world = load_world(name)
    if site:  # the task is the site's (the world reads the site)
        if name != sites:
            raise CliError(f"--site: only --world {sites} reads a site file, not {name}")
        path, scenario, intent = args.scenario, args.scenario, None
    else:
        path = scenario_arg(name, args.scenario)
        scenario, intent = _suite_task(name, path)
    try:
        method = MethodConfig(
            method=args.method,
            decoding=args.decoding,
            votes=args.votes,
            scoring=args.scoring,
            task=str(args.scenario),
        )
        assists = parse_assists(args.assists or args.protocol)
        settings = LoopSettings(
            method=method,
            max_rounds=args.rounds,
            deadline=args.deadline,
            assists=assists,
            success=intent,
        )
        options = run_options(args)
    except ValueError as e:
        raise CliError(str(e)) from None
    if args.with_replan and (args.no_llm or not args.out):
        raise CliError("--with-replan needs --out and an LLM (not --no-llm)")
    llm = None if args.no_llm else _llm(args.llm, args.record, name, args.method)
    what = "no LLM" if llm is None else f"{args.llm} ({args.method})"
    status = escape(f"running {args.scenario} in {world.title} with {what} ...")
    kept = f" (the rounds so far are in {args.out})" if args.out else ""
    try:
        with _watched(args, console) as observer, console.status(status), naming(path):
            if llm is None:
                result = run_once(world, scenario, options, args.out, observer)
            else:
                result = run(world, scenario, llm, settings, options, args.out, None, observer)
    except LLMError as e:
        raise CliError(f"{e}{kept}", ExitCode.LLM) from None
    except KeyboardInterrupt:
        raise CliError(f"interrupted{kept}", ExitCode.INTERRUPTED) from None
    _print_rounds(result, console)
    about: dict[str, Any] = {"world": world.title, "task": result.rounds[0].goal}
    description = None if getattr(args, "site", None) else world.scenarios().get(args.scenario)
    if description:  # what happens in the scenario (where a moved object went), on the page
        about["description"] = description
    if args.out and assists.label != "assisted":
        about["assists"] = assists.label
    if args.with_replan:
        about["baseline"] = _replan_run(args, world, scenario, settings, options, console)
    if args.out:
        console.print(f"wrote the run folder {args.out} (start with loop.md)")
        web_report(args, console, **about)
    verdict = "[bold green]task done[/]" if result.success else "[bold red]not done[/]"
    console.print(f"{verdict}: {escape(printable(result.message, keep_newlines=False))}")
    belief_and_truth(result, console)
    return 0 if result.success else 1


def _suite_task(world: str, path: str) -> tuple[Any, str | None]:
    """A judged task file (for the household: a scenario with a ``[judge]`` table) runs as
    ``bench prompting`` runs it: its scenario, ended by its intent (``[judge] success``), so
    that the same task, seed and LLM give the same rounds in both. Anything else is returned
    as it is (no intent)."""
    from llmpas.system.catalog import judged_task

    try:
        found = judged_task(world, path)
    except InputError as e:
        raise CliError(str(e)) from None
    return (path, None) if found is None else found


def _live_address(args: argparse.Namespace) -> Any:
    """The ``--live`` address (None: no live view); a bad value is one usage line."""
    from llmpas.reporting.live import LiveError, parse_address

    if args.live is None:
        if args.live_wait:
            raise CliError("--live-wait needs --live")
        return None
    try:
        return parse_address(args.live)
    except LiveError as e:
        raise CliError(str(e)) from None


@contextmanager
def _watched(args: argparse.Namespace, console: Console) -> Iterator[Any]:
    """The run's viewer: the Foxglove channels into ``OUT/run.mcap`` (with ``--out``) and to
    a live server (``--live``); None (nothing built, nothing listening) with neither."""
    address = _live_address(args)
    if address is None and not args.out:
        yield None
        return
    from llmpas.reporting.live import FoxgloveSink, LiveError

    mcap = Path(args.out) / "run.mcap" if args.out else None
    try:
        sink = FoxgloveSink(mcap, address).__enter__()
    except LiveError as e:
        raise CliError(str(e), ExitCode.IO) from None
    try:
        if sink.url:
            console.print(
                f"live: Foxglove WebSocket at {sink.url} (Foxglove: Open connection, "
                "Foxglove WebSocket; layout: docs/foxglove-layout.json)",
                highlight=False,
            )
            if args.live_wait:
                console.print("live: waiting for a viewer to subscribe (Ctrl-C ends it)")
                sink.wait_for_viewer()
        yield sink
    finally:
        sink.close()


def _replan_run(
    args: argparse.Namespace,
    world: Any,
    scenario: Any,
    settings: Any,
    options: Any,
    console: Console,
) -> str:
    """The replan-only run of the same scenario and seed (no LLM: the task restated), in
    ``OUT/replan-only``; its folder relative to ``OUT`` (for the page's link)."""
    from llmpas.reporting.page import build_report
    from llmpas.system import run

    folder = Path(args.out) / "replan-only"
    replan = _llm("replan", None, world_name(args), args.method)
    status = escape(f"running {args.scenario} again with replan (no LLM) ...")
    from llmpas.reporting.live import FoxgloveSink

    with console.status(status), naming(scenario), FoxgloveSink(folder / "run.mcap") as sink:
        base = run(world, scenario, replan, settings, options, folder, None, sink)
    verdict = "task done" if base.success else "not done"
    console.print(f"replan only: {verdict}: {escape(printable(base.message, keep_newlines=False))}")
    build_report(folder, {"scenario": args.scenario, "world": world.title, "llm": "replan"})
    return "replan-only"


def _print_rounds(result: Any, console: Console) -> None:
    say = partial(console.print, highlight=False, markup=False)  # LLM text is not markup
    for i, rnd in enumerate(result.rounds):
        ep = rnd.episode
        status = ep.status.value if ep else f"no plan ({rnd.plan.status.value})"
        say(f"round {i}: goal {rnd.goal} -> {status}")
        if ep is not None and ep.anomaly is not None:
            say(f"  anomaly: {ep.anomaly.constraint} ({ep.anomaly.reason})")
        if rnd.proposal is not None:
            p = rnd.proposal
            goals = " ".join(map(str, p.goals)) or p.parse.status.value
            say(f"  {p.method}: {goals} ({p.repairs} repairs, {p.latency:.1f} s)")


def add_run(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reasoning.assists import PROTOCOLS, Assists
    from llmpas.reasoning.backends.backend_registry import add_llm_argument
    from llmpas.reasoning.methods import DECODINGS, SCORINGS, method_names
    from llmpas.system.catalog import scenario_help

    p = sub.add_parser("run", help="the closed loop: plan, execute, reason about anomalies")
    p.add_argument(
        "scenario",
        help=f"a scenario: {scenario_help()}",
    )
    add_world_option(p)
    p.add_argument("--gui", action="store_true", help="open the simulator window (PyBullet)")
    p.add_argument(
        "--robot-profile",
        metavar="FILE",
        help="the robot's profile (YAML: names, namespace, QoS, places; a shipped name: "
        "pybullet, pybullet-standard) for worlds that drive a robot (ros2; docs/ros.md)",
    )
    p.add_argument(
        "--site",
        metavar="FILE",
        help="the site (YAML: places, furniture, object classes, told objects, tasks; a shipped "
        "name: house, workshop); SCENARIO is then one of its tasks (--world ros2; docs/ros.md)",
    )
    p.add_argument("--no-llm", action="store_true", help="plan and execute once, no reasoning")
    add_llm_argument(p, replan=True)
    p.add_argument("--method", default="flp", choices=method_names())
    p.add_argument(
        "--scoring",
        default="mean",
        choices=SCORINGS,
        help="how flp-choose and prior score candidates (mean, diff, pmi; -words: plain words)",
    )
    p.add_argument("--decoding", default="grammar", choices=DECODINGS)
    p.add_argument("--rounds", type=positive_int, default=3, help="LLM consultations at most")
    p.add_argument(
        "--protocol",
        default="assisted",
        choices=tuple(PROTOCOLS),
        help="paper: the LLM's goals are parsed and syntax-checked only (no search rewriting, "
        "grammar pruning, list of unsearched places, validation or repair); assisted: all",
    )
    p.add_argument(
        "--assists",
        help="exactly these assists, comma-separated (overrides --protocol): "
        + ", ".join(Assists.names()),
    )
    p.add_argument(
        "--votes",
        type=positive_int,
        default=1,
        help="self-consistency: answers sampled per consultation, each checked, the most "
        "agreed valid one taken (1: off)",
    )
    p.add_argument(
        "--with-replan",
        action="store_true",
        help="also run the same scenario and seed with replan (no LLM) into OUT/replan-only; "
        "the web page compares the two",
    )
    p.add_argument(
        "--deadline",
        type=positive_float,
        help="seconds for the whole loop: it stops cleanly between steps (status: deadline)",
    )
    p.add_argument("--record", help="record the LLM's answers into this cassette folder")
    p.add_argument(
        "--out",
        help="folder for loop.md, loop.json (rewritten after every round), reports and "
        "run.mcap (the Foxglove channels of the run)",
    )
    p.add_argument(
        "--live",
        nargs="?",
        const="127.0.0.1:8765",
        metavar="HOST:PORT",
        help="watch the loop live in Foxglove: a WebSocket server for the run "
        "(default 127.0.0.1:8765; another interface only when named; docs/live.md)",
    )
    p.add_argument(
        "--live-wait",
        action="store_true",
        help="with --live: start the loop when a viewer has subscribed",
    )
    add_planner_options(p)
    p.set_defaults(handler=_cmd_run, seed=None)


__all__ = ["add_run"]
