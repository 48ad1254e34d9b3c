"""The prompting experiment (the paper's Table II): every prompting method on the household
anomaly suite (:mod:`llmpas.experiments.suite`), judged automatically in the closed loop.

For each method, task and sample the closed loop runs the task with the LLM; the sample succeeds
when the loop resolves the anomaly and the task's success condition holds on the TRUE final
state (:func:`llmpas.experiments.suite.judge`). Samples differ by the LLM's seed (``seed + k``)
at ``temperature``; the world is the same in every sample.

Per task i: ``SR_i`` = the share of successful samples, ``L̄_i`` = the mean resolution length of
the successful samples. Per anomaly type with n tasks (10, 8, 8 in the shipped suite)::

    SR   = (1/n) Σ_i SR_i
    ASPL = (1/n) Σ_i (L̄_i / L_gt,i) × SR_i        (a task with SR_i = 0 adds 0)

plus the syntax-error rate (goal answers that did not parse / goal answers), repairs, tokens and
LLM latency per sample, and the end-to-end completion rate of the closed loop (the loop reported
the task done). The ``oracle`` row (the labelled oracle answers from the simulator's true state;
an upper bound, never a default) runs one sample per task (it is deterministic).

What the LLM contributes, beside SR and ASPL:

- the ``replan`` row (:mod:`llmpas.reasoning.replan`; a baseline, not an oracle): a backend
  that answers every goal request with the task goal restated, in the same loop with the same
  budget (the oracle's path: ``flp``, one sample per task). Each method's **lift** is its SR minus
  replan's, per anomaly type and overall: what its reasoning adds to replanning the task from the
  robot's belief (which already resolves an anomaly whose cause the robot perceived).
- the **first-proposal effective rate**: the share of samples whose first goal answer entails one
  of the task's effective goal sets (``[judge] effective``; the rule:
  :mod:`llmpas.experiments.effective`), over the samples of tasks that list sets.

Another world (``--world NAME``, default the household's suite): its shipped scenarios are the
tasks, judged from the loop's own verdict against the world's truth
(:mod:`llmpas.experiments.world_tasks`), the world's name the anomaly type's column, no ASPL (no
``l_gt``) and no first-proposal effective rate (no effective sets).

Each (method, task, sample) is a cached job (:mod:`llmpas.experiments.jobs`): an interrupted run
resumes, ``jobs`` runs them in parallel processes. Writes ``prompting.md`` (Table II and the extra
metrics), ``prompting.csv`` (one row per method and anomaly type), ``prompting.json`` (the same
cells with the run's settings), ``prompting_samples.csv`` (one row per sample) and
``prompting.png``.
"""

from __future__ import annotations

import argparse
import hashlib
import logging
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.harness import (
    Harnessed,
    Shared,
    SharedOptions,
    run_trials,
    shared_from_args,
)
from llmpas.experiments.jobs import (
    Job,
    add_llm_argument,
    backend,
    cache_file,
    fingerprint,
    llm_resources,
)
from llmpas.experiments.prompting_config import (
    BASELINE,
    ORACLE,
    REPLAN_VERSION,
    SUITE_WORLD,
    UPPER_BOUND,
    Payload,
    PromptingConfig,
    plan_rows,
    row_id,
    rows,
    variants,
)
from llmpas.experiments.prompting_tables import (
    Cell,
    ablation_lines,
    control_lines,
    markdown_table,
    method_label,
    summarise,
    wilson,
    write_outputs,
)
from llmpas.experiments.suite import (
    HALVES,
    SUITE_DIR,
    Judgement,
    SuiteTask,
    development_half,
    judge,
    load_suite,
    load_task,
    parse_task,
)
from llmpas.experiments.world_tasks import WorldTask, judge_scenario, world_task, world_tasks
from llmpas.experiments.worlds import LoopConfig
from llmpas.planning import PlannerConfig
from llmpas.reasoning.assists import Assists
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import (
    DECODINGS,
    PAPER_METHODS,
    REGISTRY,
    SCORINGS,
    MethodConfig,
    method_names,
)
from llmpas.reasoning.replan import REPLAN, Replan
from llmpas.system import LLMFor, LoopResult, SweepBudget
from llmpas.system.catalog import oracle_for
from llmpas.worlds.api import RunOptions

log = logging.getLogger(__name__)


# ------------------------------------------------------------------------------- backends


def build_llm(spec: str, record: str | None = None, world: str = SUITE_WORLD) -> LLM | LLMFor:
    """The backend for ``spec`` (``oracle``: the oracle factory of ``world``), built once per
    process (a local model is loaded once, not per job: :func:`~llmpas.experiments.jobs.backend`).
    ValueError for a bad spec."""
    if spec == ORACLE:
        return oracle_for(world)
    llm: LLM = backend(spec, record)
    return llm


def loop_config(
    config: PromptingConfig,
    method: str,
    sample: int,
    assists: Assists | None = None,
    task: str = "",
) -> LoopConfig:
    """The closed loop of one sample: the method's config with the sample's LLM seed, and the
    protocol's assists (default: all); ``task``: the task's name, given to the methods that
    seed an order with it (``candidates-shuffled``)."""
    is_oracle = method in (ORACLE, REPLAN)  # deterministic rows: the oracle's path
    shuffled = not is_oracle and REGISTRY[method].chooser == "shuffled"
    return LoopConfig(
        assists=assists or Assists(),
        method=MethodConfig(
            method="flp" if is_oracle else method,
            decoding=config.decoding,
            repairs=config.repairs,
            temperature=0.0 if is_oracle else config.temperature,
            seed=config.seed + sample,
            max_tokens=config.max_tokens,
            votes=1 if is_oracle else config.votes,
            scoring=config.scoring,
            task=task if shuffled else "",
        ),
        max_rounds=config.max_rounds,
        sweep=SweepBudget(places=config.sweep_places),
        options=RunOptions(planner=PlannerConfig.validation(max_time=config.max_time)),
    )


def run_job(payload: Payload) -> dict[str, Any]:
    """Judge one sample (module level: it may run in another process)."""
    if payload.world != SUITE_WORLD:
        return _run_scenario_job(payload)
    if payload.task_data is None:
        task = load_task(payload.task_file)
    else:
        task = parse_task(payload.task_data, payload.task_file)
    llm = (
        Replan(task.scenario.goal, payload.loop.method.method)
        if payload.method == REPLAN
        else build_llm(payload.llm, payload.record)
    )
    keep = _keeper(payload, task.name, task.scenario.goal) if payload.keep else None
    return _record(payload, task.l_gt, judge(task, llm, payload.loop, keep))


def _run_scenario_job(payload: Payload) -> dict[str, Any]:
    """Judge one sample of a world's scenario (:mod:`llmpas.experiments.world_tasks`): replan
    restates the session's task; the oracle is the world's."""
    task = world_task(payload.world, payload.task_file)
    method = payload.loop.method.method
    llm: LLM | LLMFor = (
        (lambda session: Replan(session.task, method))
        if payload.method == REPLAN
        else build_llm(payload.llm, payload.record, payload.world)
    )
    keep = _keeper(payload, task.name) if payload.keep else None
    return _record(payload, task.l_gt, judge_scenario(task, llm, payload.loop, keep))


def _record(payload: Payload, l_gt: int | None, j: Judgement) -> dict[str, Any]:
    """A sample's row of ``prompting_samples.csv``."""
    log.info("%s %s #%d: %s", payload.method, j.task, payload.sample, j.verdict.value)
    return {
        "method": payload.row or payload.method,
        "protocol": payload.loop.assists.label,
        "sample": payload.sample,
        "l_gt": l_gt,
        **j.to_json(),
    }


def _keeper(payload: Payload, name: str, goal: str | None = None) -> Callable[[LoopResult], object]:
    """Saves a run's ``loop.json`` and its web report into ``payload.keep`` (``goal``: the
    task's; None: the first round's)."""

    def keep(result: LoopResult) -> None:
        from llmpas.reporting import build_report

        folder = Path(str(payload.keep))
        result.save(folder / "loop.json")
        task = goal if goal is not None else result.rounds[0].goal if result.rounds else ""
        about = {"scenario": name, "world": payload.world, "llm": payload.llm}
        build_report(folder, about | {"method": payload.method, "task": task})

    return keep


def run_folder(config: PromptingConfig, key: str) -> Path:
    """Where the run of job ``key`` is kept (with ``keep_runs``)."""
    path = cache_file(config.out_dir / "runs", key)
    return path.with_name(path.stem)


# -------------------------------------------------------------------------------------- run


@dataclass(frozen=True)
class Report:
    records: tuple[dict[str, Any], ...]
    cells: tuple[Cell, ...]
    files: tuple[Path, ...] = field(default=())


def _loop_key(loop: LoopConfig) -> dict[str, Any]:
    """The loop's config as its jobs' cache keys hold it: the method's ``scoring`` and
    ``task`` left out at their defaults, so that the runs cached before they existed are kept."""
    data = asdict(loop)
    method = data["method"]
    for name, default in (("scoring", "mean"), ("task", "")):
        if method.get(name) == default:
            del method[name]
    return data


def jobs_for(
    config: PromptingConfig, tasks: Sequence[SuiteTask] | Sequence[WorldTask]
) -> list[Job[Payload]]:
    out = []
    data = {t.source: _content(t) if isinstance(t, SuiteTask) else None for t in tasks}
    name = (lambda t: t.source) if config.on_suite else (lambda t: t.name)
    for row, method, assists in plan_rows(config):
        is_fixed = method in (ORACLE, REPLAN)  # deterministic, never an LLM: one sample
        llm = method if is_fixed else config.llm
        record = None if is_fixed or config.record is None else str(config.record)
        for t in tasks:
            for k in range(1 if is_fixed else config.samples):
                loop = loop_config(config, method, k, assists, t.name)
                prompts = (
                    ""
                    if method == ORACLE
                    else REPLAN_VERSION
                    if method == REPLAN
                    else _templates_digest()
                )
                digest = fingerprint([t.digest, _loop_key(loop), llm, record, prompts])
                key = f"{_safe(row)}/{_safe(llm)}/{t.name}/s{k}/{digest}"
                keep = str(run_folder(config, key)) if config.keep_runs else None
                payload = Payload(
                    name(t), method, k, llm, record, loop, data[t.source], keep, row, config.world
                )
                out.append(Job(key, payload, {} if is_fixed else llm_resources(llm)))
    return out


def _content(task: SuiteTask) -> bytes | None:
    """The task file's content, when it is still what the task was read from (its digest)."""
    try:
        raw = Path(task.source).read_bytes()
    except OSError:
        return None
    return raw if hashlib.sha256(raw).hexdigest() == task.digest else None


def run_prompting(config: PromptingConfig, console: Console | None = None) -> Report:
    """Run (or resume) the experiment and write the table, CSVs and plot."""
    console = console or Console()
    tasks = _tasks(config)
    jobs = jobs_for(config, tasks)
    if (
        config.methods
        and config.llm != ORACLE
        and config.jobs == 1
        and config.executor.kind == "local"
    ):
        # fail early on a bad spec (with --jobs N each worker process builds its own backend:
        # a local model is then loaded N times)
        build_llm(config.llm, None if config.record is None else str(config.record), config.world)
    records = run_trials(config, jobs, run_job, "prompting", console)
    cells = summarise(records, rows(config))
    files = write_outputs(records, cells, config)
    table = markdown_table(cells, config, records)
    console.print(table, soft_wrap=True, highlight=False, markup=False)
    return Report(tuple(records), cells, files)


def _tasks(config: PromptingConfig) -> tuple[SuiteTask, ...] | tuple[WorldTask, ...]:
    """The run's tasks: the suite's (``--tasks``, ``--measures-llm``, ``--half``), or the world's
    scenarios (``--tasks``: their names)."""
    if not config.on_suite:
        return world_tasks(config.world, config.tasks)
    tasks = load_suite(config.suite, config.tasks)
    if config.measures_llm:
        tasks = tuple(t for t in tasks if t.measures_llm)
        if not tasks:
            raise ValueError(f"{config.suite}: no task is marked measures_llm")
    if config.half:
        development = development_half(load_suite(config.suite))  # of the whole suite
        keep = config.half == "development"
        tasks = tuple(t for t in tasks if (t.name in development) == keep)
    return tasks


def _templates_digest() -> str:
    """A hash of the prompt templates: edited prompts never reuse cached answers."""
    from importlib import resources

    folder = resources.files("llmpas.reasoning").joinpath("templates")
    texts = sorted((f.name, f.read_text(encoding="utf-8")) for f in folder.iterdir() if f.is_file())
    return fingerprint(texts)


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)[:40]


# -------------------------------------------------------------------------------------- CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench prompting``."""
    add_llm_argument(p)
    p.add_argument(
        "--methods",
        nargs="+",
        default=["all"],
        help="prompting methods: all, paper (the paper's five), none (the oracle and replan "
        "rows only), or some of " + ", ".join(method_names()),
    )
    p.add_argument(
        "--no-oracle", action="store_true", help="leave out the oracle (upper-bound) row"
    )
    p.add_argument(
        "--no-replan",
        action="store_true",
        help="leave out the replan row (no reasoning: the task goal restated) and the lifts",
    )
    p.add_argument(
        "--measures-llm",
        action="store_true",
        help="only the tasks marked measures_llm (the replan baseline fails them)",
    )
    p.add_argument(
        "--half",
        choices=HALVES,
        help="only the development half of the suite (per category, the first half by the "
        "SHA-256 of the task names), or the rest",
    )
    p.add_argument(
        "--protocol",
        nargs="+",
        default=["assisted"],
        help="paper (goals parsed and syntax-checked only) and/or assisted (today's loop), or "
        "assists joined by '+' (" + ", ".join(Assists.names()) + "); each gets its rows",
    )
    p.add_argument(
        "--assists",
        action="store_true",
        help="the ablation: the methods also with no assist, each assist alone, and all",
    )
    p.add_argument(
        "--votes", type=int, default=1, help="self-consistency: checked answers per consultation"
    )
    p.add_argument("--samples", type=int, default=3, help="samples per task and method")
    p.add_argument("--temperature", type=float, default=0.7)
    p.add_argument("--seed", type=int, default=0, help="LLM seed of the first sample")
    p.add_argument("--decoding", default="grammar", choices=DECODINGS)
    p.add_argument("--repairs", type=int, default=2, help="repair prompts per answer at most")
    p.add_argument("--rounds", type=int, default=3, help="LLM consultations per run at most")
    p.add_argument(
        "--max-time",
        type=float,
        default=600.0,
        help="planner safety net, seconds per plan (counted limits decide the verdict)",
    )
    p.add_argument(
        "--sweep-places",
        type=int,
        default=SweepBudget().places,
        help="places one object-loss consultation searches at most (1: one a consultation)",
    )
    p.add_argument("--suite", default=str(SUITE_DIR), help="folder of task files")
    p.add_argument("--tasks", nargs="+", help="only these tasks (file stems)")
    p.add_argument("--record", help="record the LLM's answers into this cassette folder")
    p.add_argument(
        "--scoring",
        default="mean",
        choices=SCORINGS,
        help="how flp-choose and prior score candidates: mean, diff (the tokens where they "
        "differ), pmi (against the prompt without the evidence); -words: as plain words",
    )
    p.add_argument(
        "--keep-runs",
        action="store_true",
        help="keep every run (OUT/runs/..., linked from index.html)",
    )


def config_from_args(args: argparse.Namespace, shared: Shared | None = None) -> PromptingConfig:
    """The config of ``llmpas bench prompting``'s options (``shared``: the shared ones, default:
    read from ``args``)."""
    shared = shared or shared_from_args(args)
    methods = (
        method_names()
        if "all" in args.methods
        else PAPER_METHODS
        if args.methods == ["paper"]
        else ()
        if args.methods == ["none"]
        else tuple(args.methods)
    )
    return PromptingConfig(
        llm=args.llm,
        methods=methods,
        oracle=not args.no_oracle,
        replan=not getattr(args, "no_replan", False),
        measures_llm=getattr(args, "measures_llm", False),
        half=getattr(args, "half", None) or "",
        samples=args.samples,
        temperature=args.temperature,
        seed=args.seed,
        decoding=args.decoding,
        repairs=args.repairs,
        max_rounds=args.rounds,
        sweep_places=getattr(args, "sweep_places", SweepBudget().places),
        max_time=args.max_time,
        suite=Path(args.suite),
        tasks=tuple(args.tasks) if args.tasks else None,
        record=Path(args.record) if args.record else None,
        jobs=shared.jobs,
        out_dir=shared.out_dir,
        executor=shared.executor,
        keep_runs=getattr(args, "keep_runs", False),
        protocols=tuple(getattr(args, "protocol", None) or ("assisted",)),
        ablation=getattr(args, "assists", False),
        votes=getattr(args, "votes", 1),
        scoring=getattr(args, "scoring", "mean"),
        world=getattr(args, "world", None) or SUITE_WORLD,
    )


def _arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench prompting``: :func:`add_arguments` and ``--world`` (a
    benchmark that runs the suite through it, ``bench recovery``, takes the others only)."""
    add_arguments(p)
    p.add_argument(
        "--world",
        default=SUITE_WORLD,
        help=f"whose tasks: {SUITE_WORLD} (the anomaly suite, --suite), or any registered world "
        "or your own package.module:WORLD, whose shipped scenarios are then the tasks (all, or "
        "those --tasks names), each judged from the loop's own verdict and the world's truth",
    )


def _run(config: PromptingConfig, console: Console) -> tuple[Path, ...]:
    """``llmpas bench prompting``; user errors are ValueError / LLMError with one line."""
    return run_prompting(config, console).files


#: The shared options of ``bench prompting`` (and ``bench recovery``).
SHARED = SharedOptions(
    out="results/prompting",
    out_help="folder for tables, plot, cache",
    jobs_help="samples run in parallel processes",
)


QUICK_TASKS = ("ol01-table2", "ab06-sink-mug", "sc06-apple-frozen-stove")  # bench all --quick


def _in_all(config: AllConfig) -> tuple[str, ...]:
    methods = "none" if config.llm == ORACLE else "all"  # oracle: its row only
    samples = "1" if config.quick else str(config.samples)
    tasks = ("--tasks", *QUICK_TASKS) if config.quick else ()
    options = ("--llm", config.llm, "--methods", methods, "--samples", samples, *tasks)
    return (*options, *config.jobs_argv(), *config.outputs("prompting"))


BENCHMARK = Harnessed(
    "prompting",
    "prompting methods on the household anomaly suite (or a world's scenarios: --world)",
    _arguments,
    config_from_args,
    _run,
    SHARED,
    _in_all,
)

__all__ = [
    "BASELINE",
    "BENCHMARK",
    "ORACLE",
    "QUICK_TASKS",
    "REPLAN",
    "SHARED",
    "UPPER_BOUND",
    "Cell",
    "Payload",
    "PromptingConfig",
    "Report",
    "ablation_lines",
    "add_arguments",
    "build_llm",
    "config_from_args",
    "control_lines",
    "jobs_for",
    "loop_config",
    "markdown_table",
    "method_label",
    "plan_rows",
    "row_id",
    "rows",
    "run_job",
    "run_prompting",
    "summarise",
    "variants",
    "wilson",
    "write_outputs",
]
