"""The seed paper's blocks-world experiment (Table III): LLMs as planners with 3, 5 and 7 blocks.

Methods (see :mod:`llmpas.experiments.blocks.planners`): ``llm-ic`` (one in-context example),
``copal`` (execute, back-prompt with the failure, bounded rounds), ``flp`` (First Look Prompting
with the task as the anomaly), and ``oracle`` (Fast Downward's optimal plan; an upper bound, no
LLM). Every plan is parsed as data and judged by simulating the domain step by step.

Tasks are generated (``count`` seeds per size) or read from a folder of PDDL problem files,
written for the shipped domain or for any four-operator blocks domain given with ``--domain``
(``on-table``, ``arm-empty``, ... : the names' roles are read from the actions). Each
(task, method) is a cached job (:mod:`llmpas.experiments.jobs`): an interrupted run resumes, and
``jobs`` runs them in parallel processes. Writes ``blocksworld.md`` (SR per method and size),
``blocksworld.csv`` (one row per task and method), ``blocksworld_summary.csv`` and
``blocksworld.png``.
"""

from __future__ import annotations

import argparse
import logging
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.blocks.blocks_tasks import (
    OPTIMAL_SEARCH,
    Task,
    domain_text,
    generated_tasks,
    read_tasks,
    reference_plan,
)
from llmpas.experiments.blocks.planners import (
    DECODINGS,
    METHODS,
    PROMPT_VERSION,
    TEMPLATES,
    ReferenceOracle,
    Settings,
    run_method,
)
from llmpas.experiments.blocks.plans import Outcome, Step
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions, rows_of, run_trials
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    add_llm_argument,
    backend,
    fingerprint,
    llm_resources,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.planning.downward import ClassicalStatus
from llmpas.reasoning.backends.backend_registry import BACKENDS, choices
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import template

log = logging.getLogger(__name__)

LLM_KINDS = ("oracle", *BACKENDS)  # the backend registry's kinds, and the reference oracle
UPPER_BOUND = "upper bound"


@dataclass(frozen=True)
class BlocksConfig:
    """One run of the experiment.

    ``llm``: ``oracle`` (Fast Downward's plan answered as if by an LLM: an upper bound) |
    ``replay:DIR`` | ``openai:MODEL[@URL]`` | ``llama-cpp[:PATH]``; ``record``: a cassette folder
    the LLM's answers are recorded into. ``problems``: a folder of PDDL problem files used
    instead of generated instances (``sizes``, ``count`` and ``seed`` then do not apply);
    ``domain``: the blocks domain those files are written for (default: the shipped one).
    """

    methods: tuple[str, ...] = METHODS
    sizes: tuple[int, ...] = (3, 5, 7)
    count: int = 20
    seed: int = 0
    problems: Path | None = None
    domain: Path | None = None
    llm: str = "llama-cpp"
    record: Path | None = None
    settings: Settings = field(default_factory=Settings)
    jobs: int = 1
    out_dir: Path = Path("results/blocksworld")
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)

    def __post_init__(self) -> None:
        if not self.methods:
            raise ValueError("give at least one method")
        bad = [m for m in self.methods if m not in METHODS]
        if bad:
            raise ValueError(f"unknown method {bad[0]!r}; methods: {', '.join(METHODS)}")
        if len(set(self.methods)) != len(self.methods):
            raise ValueError("methods must not repeat")
        if not self.sizes or min(self.sizes) < 2:
            raise ValueError(f"sizes must be numbers of blocks >= 2, got {self.sizes}")
        if self.count < 1:
            raise ValueError(f"count must be >= 1, got {self.count}")
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")
        kind = self.llm.partition(":")[0]
        if kind not in LLM_KINDS:
            raise ValueError(f"llm {self.llm!r}: expected {choices(LLM_KINDS)}")
        if self.domain is not None and self.problems is None:
            raise ValueError("--domain needs --problems (the problem files written for it)")
        if kind == "oracle" and self.record is not None:
            raise ValueError("recording does not apply to the oracle")

    @property
    def oracle_llm(self) -> bool:
        return self.llm == "oracle"


@dataclass(frozen=True)
class Payload:
    """Everything one job needs (picklable: the LLM is a spec, built in the worker)."""

    method: str
    task: Task
    reference: tuple[Step, ...]
    llm: str
    record: str | None
    settings: Settings
    model: LLM | None = None  # an LLM object instead of the spec (tests; one process)
    # why there is no reference plan (the optimal search's status and message); "" when solved
    reference_note: str = ""


@dataclass(frozen=True)
class TaskResult:
    """One task solved (or not) by one method: a row of ``blocksworld.csv``."""

    task: str
    size: int
    seed: int | None
    method: str
    llm: str
    success: bool
    outcome: str
    message: str
    plan_length: int
    optimal_length: int | None
    rounds: int
    syntax_errors: int
    tokens: int
    latency: float

    @property
    def ratio(self) -> float | None:
        if not self.success or not self.optimal_length:
            return None
        return self.plan_length / self.optimal_length


@dataclass(frozen=True)
class Row:
    """SR and means for one method at one size."""

    method: str
    label: str
    size: int
    tasks: int
    solved: int
    length_ratio: float | None  # mean plan length / optimal over solved tasks
    rounds: float
    syntax_errors: int
    tokens: float
    latency: float

    @property
    def sr(self) -> float:
        return self.solved / self.tasks if self.tasks else 0.0


@dataclass(frozen=True)
class Report:
    outcomes: tuple[TaskResult, ...]
    rows: tuple[Row, ...]
    files: tuple[Path, ...] = ()


# ------------------------------------------------------------------------------------ LLM


def build_llm(spec: str, record: str | None) -> LLM:
    """The backend for ``spec`` (not ``oracle``), built once per process (:func:`backend`)."""
    llm: LLM = backend(spec, record)
    return llm


def method_label(method: str, llm: str) -> str:
    """The name of a table row; upper bounds say so."""
    if method == "oracle":
        return f"oracle (Fast Downward plan; {UPPER_BOUND})"
    if llm == "oracle":
        return f"{method} with the oracle LLM ({UPPER_BOUND})"
    return method


# ----------------------------------------------------------------------------------- jobs


def run_job(payload: Payload) -> dict[str, Any]:
    """Run one method on one task (a module-level function: it may run in another process)."""
    task = payload.task
    problem = task.problem()
    llm: LLM
    if payload.method == "oracle":
        llm = ReferenceOracle(payload.reference)
    elif payload.model is not None:
        llm = payload.model
    elif payload.llm == "oracle":
        llm = ReferenceOracle(payload.reference)
    else:
        llm = build_llm(payload.llm, payload.record)
    if isinstance(llm, ReferenceOracle) and payload.reference_note:
        return _no_reference(payload)
    attempt = run_method(payload.method, problem, llm, payload.settings, task.domain_text)
    optimal = len(payload.reference) if payload.reference else None
    outcome = TaskResult(
        task.name,
        task.size,
        task.seed,
        payload.method,
        "" if payload.method == "oracle" else payload.llm,
        attempt.verdict.success,
        attempt.verdict.outcome.value,
        attempt.verdict.message,
        len(attempt.steps),
        optimal,
        attempt.rounds,
        attempt.syntax_errors,
        attempt.tokens,
        round(attempt.latency, 3),
    )
    return {
        **asdict(outcome),
        "first_look": attempt.first_look,
        "plan": [str(s) for s in attempt.steps],
        "turns": [asdict(t) for t in attempt.turns],
    }


def _no_reference(payload: Payload) -> dict[str, Any]:
    """The oracle's row when Fast Downward found no optimal plan: a failure that says so (the
    oracle has nothing to answer; no answer's format is to blame)."""
    task = payload.task
    outcome = TaskResult(
        task.name,
        task.size,
        task.seed,
        payload.method,
        "" if payload.method == "oracle" else payload.llm,
        False,
        Outcome.NO_REFERENCE.value,
        f"no reference plan: {payload.reference_note}",
        0,
        None,
        0,
        0,
        0,
        0.0,
    )
    return {**asdict(outcome), "first_look": "", "plan": [], "turns": []}


def _reference_note(result: Mapping[str, Any]) -> str:
    """Why the optimal search gave no plan ("" when it solved the task)."""
    if result["status"] == ClassicalStatus.SOLVED.value:
        return ""
    why = f": {result['message']}" if result["message"] else ""
    return f"Fast Downward's optimal search: {result['status']}{why}"


def _reference_job(task: Task) -> dict[str, Any]:
    ref = reference_plan(task)
    return {
        "status": ref.status.value,
        "message": ref.message,
        "plan": [[s.action, *s.args] for s in ref.steps],
    }


def load_tasks(config: BlocksConfig) -> list[Task]:
    if config.problems is not None:
        return read_tasks(config.problems, config.domain)
    return generated_tasks(config.sizes, config.count, config.seed)


def run_blocksworld(
    config: BlocksConfig, console: Console | None = None, llm: LLM | None = None
) -> Report:
    """Run every (task, method) not cached yet, then write the tables and the plot.

    ``llm``: an LLM object to use instead of ``config.llm`` (it must be picklable when
    ``config.jobs > 1``); its ``name`` labels the results and keys the cache."""
    console = console or Console(stderr=True)
    tasks = load_tasks(config)
    refs = run_trials(
        config,
        [Job(f"reference/{t.name}/{fingerprint(_task_key(t, OPTIMAL_SEARCH))}", t) for t in tasks],
        _reference_job,
        "reference plans (Fast Downward)",
        console,
    )
    references = {
        t.name: tuple(Step(p[0], tuple(p[1:])) for p in r["plan"])
        for t, r in zip(tasks, refs, strict=True)
    }
    notes = {t.name: _reference_note(r) for t, r in zip(tasks, refs, strict=True)}
    llm_name = config.llm if llm is None else str(getattr(llm, "name", type(llm).__name__))
    prompts = fingerprint(
        [PROMPT_VERSION, domain_text(), *(template(n).template for n in TEMPLATES)]
    )
    jobs = []
    for method in config.methods:
        uses_llm = method != "oracle"
        key_llm = llm_name if uses_llm else "none"
        settings = asdict(config.settings) if uses_llm else {}
        for t in tasks:
            note = [notes[t.name]] if notes[t.name] else []  # keys of solved tasks unchanged
            digest = fingerprint(
                [*_task_key(t), references[t.name], settings, prompts, key_llm, *note]
            )
            payload = Payload(
                method,
                t,
                references[t.name],
                llm_name,
                _str(config.record),
                config.settings,
                llm if uses_llm else None,
                notes[t.name],
            )
            needs = llm_resources(config.llm) if uses_llm and llm is None else {}
            jobs.append(Job(f"{method}/{_safe(key_llm)}/{t.name}/{digest}", payload, needs))
    results = run_trials(config, jobs, run_job, f"blocks world ({llm_name})", console)
    outcomes = tuple(rows_of(TaskResult, results))
    rows = summarise(outcomes)
    files = write_outputs(outcomes, rows, config, llm_name)
    console.print(
        markdown_table(rows, config, llm_name), soft_wrap=True, highlight=False, markup=False
    )
    return Report(outcomes, rows, files)


def _task_key(task: Task, *more: str) -> list[str]:
    """What identifies a task in cache keys (the domain only when it is not the shipped one,
    so caches written before ``--domain`` existed stay valid)."""
    return [task.text, *more, *([task.domain_text] if task.domain_text else [])]


def _str(path: Path | None) -> str | None:
    return None if path is None else str(path)


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)[:40]


# ------------------------------------------------------------------------------------ CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench blocksworld``."""
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    p.add_argument("--sizes", nargs="+", type=int, default=[3, 5, 7], help="numbers of blocks")
    p.add_argument("--count", type=int, default=20, help="generated instances per size")
    p.add_argument("--seed", type=int, default=0, help="first generator seed")
    p.add_argument("--problems", help="a folder of PDDL problem files instead of generated ones")
    p.add_argument(
        "--domain",
        help="the four-operator blocks domain the --problems files are written for "
        "(default: the shipped one; any names, e.g. on-table / arm-empty)",
    )
    add_llm_argument(p, "oracle (Fast Downward's plan: an upper bound)")
    p.add_argument("--record", help="record the LLM's answers into this cassette folder")
    p.add_argument("--rounds", type=int, default=3, help="COPAL: plan answers at most")
    p.add_argument(
        "--correction-temperature",
        type=float,
        default=Settings.correction_temperature,
        help="COPAL: sampling temperature of the corrections (the first plan is greedy)",
    )
    p.add_argument("--decoding", default="grammar", choices=DECODINGS)


def config_from(args: argparse.Namespace, shared: Shared) -> BlocksConfig:
    """The config of ``llmpas bench blocksworld``; user errors are ValueError/LLMError with
    one line."""
    return BlocksConfig(
        methods=tuple(args.methods),
        sizes=tuple(args.sizes),
        count=args.count,
        seed=args.seed,
        problems=Path(args.problems) if args.problems else None,
        domain=Path(args.domain) if args.domain else None,
        llm=args.llm,
        record=Path(args.record) if args.record else None,
        settings=Settings(
            rounds=args.rounds,
            decoding=args.decoding,
            correction_temperature=args.correction_temperature,
        ),
        jobs=shared.jobs,
        out_dir=shared.out_dir,
        executor=shared.executor,
    )


def _run(config: BlocksConfig, console: Console) -> tuple[Path, ...]:
    return run_blocksworld(config, console).files


# ---------------------------------------------------------------------------------- tables


def summarise(outcomes: Sequence[TaskResult]) -> tuple[Row, ...]:
    methods = list(dict.fromkeys(o.method for o in outcomes))
    rows = []
    for method in methods:
        for size in sorted({o.size for o in outcomes if o.method == method}):
            group = [o for o in outcomes if (o.method, o.size) == (method, size)]
            ratios = [r for o in group if (r := o.ratio) is not None]
            rows.append(
                Row(
                    method,
                    method_label(method, group[0].llm),
                    size,
                    len(group),
                    sum(o.success for o in group),
                    statistics.mean(ratios) if ratios else None,
                    statistics.mean(o.rounds for o in group),
                    sum(o.syntax_errors for o in group),
                    statistics.mean(o.tokens for o in group),
                    statistics.mean(o.latency for o in group),
                )
            )
    return tuple(rows)


def _ratio(rows: Iterable[Row]) -> str:
    rows = list(rows)
    weighted = [(r.length_ratio, r.solved) for r in rows if r.length_ratio is not None]
    total = sum(n for _, n in weighted)
    return f"{sum(x * n for x, n in weighted) / total:.2f}" if total else "—"


def markdown_table(rows: Sequence[Row], config: BlocksConfig, llm: str) -> str:
    sizes = sorted({r.size for r in rows})
    source = (
        f"problems from {config.problems}"
        + (f" (domain {config.domain})" if config.domain is not None else "")
        if config.problems is not None
        else f"{config.count} generated instances per size (seeds {config.seed}.."
        f"{config.seed + config.count - 1})"
    )
    lines = [
        f"Blocks world: success rate (SR) per number of blocks; LLM: {llm}; {source}; "
        f"COPAL at most {config.settings.rounds} answers; decoding: {config.settings.decoding}. "
        "Plans are judged by simulating the domain. Rows marked 'upper bound' do not measure "
        "an LLM.",
        "",
        "| method | " + " | ".join(f"{n} blocks" for n in sizes) + " | plan length / optimal |",
        "|---|" + "---:|" * (len(sizes) + 1),
    ]
    for method in dict.fromkeys(r.method for r in rows):
        mine = [r for r in rows if r.method == method]
        cells = []
        for n in sizes:
            r = next((r for r in mine if r.size == n), None)
            cells.append("—" if r is None else f"{r.sr:.2f} ({r.solved}/{r.tasks})")
        lines.append(f"| {mine[0].label} | " + " | ".join(cells) + f" | {_ratio(mine)} |")
    lines += [
        "",
        "| method | blocks | tasks | solved | SR | length / optimal | mean answers | "
        "syntax errors | mean tokens | mean latency (s) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        ratio = "—" if r.length_ratio is None else f"{r.length_ratio:.2f}"
        lines.append(
            f"| {r.label} | {r.size} | {r.tasks} | {r.solved} | {r.sr:.2f} | {ratio} | "
            f"{r.rounds:.2f} | {r.syntax_errors} | {r.tokens:.0f} | {r.latency:.1f} |"
        )
    return "\n".join(lines) + "\n"


def write_outputs(
    outcomes: Sequence[TaskResult], rows: Sequence[Row], config: BlocksConfig, llm: str
) -> tuple[Path, ...]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    csv_path = write_csv(out / "blocksworld.csv", [asdict(o) for o in outcomes])
    summary = write_csv(
        out / "blocksworld_summary.csv", [{**asdict(r), "sr": round(r.sr, 4)} for r in rows]
    )
    md_path = atomic_write(out / "blocksworld.md", markdown_table(rows, config, llm))
    png_path = out / "blocksworld.png"
    plot(rows, llm, png_path)
    log.info("wrote %s, %s, %s, %s", csv_path, summary, md_path, png_path)
    return (md_path, csv_path, summary, png_path)


def plot(rows: Sequence[Row], llm: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted({r.size for r in rows})
    methods = list(dict.fromkeys(r.method for r in rows))
    width = 0.8 / max(1, len(methods))
    fig, ax = plt.subplots(figsize=(1.6 + 1.4 * len(sizes) * max(1, len(methods)) / 2, 5.0))
    for i, method in enumerate(methods):
        mine = {r.size: r for r in rows if r.method == method}
        xs = [j + (i - (len(methods) - 1) / 2) * width for j in range(len(sizes))]
        ys = [mine[n].sr if n in mine else 0.0 for n in sizes]
        label = next(r.label for r in rows if r.method == method)
        hatch = "//" if UPPER_BOUND in label else None
        bars = ax.bar(xs, ys, width * 0.95, label=label, hatch=hatch, alpha=0.85)
        ax.bar_label(bars, labels=[f"{y:.2f}" for y in ys], fontsize=7, padding=1)
    ax.set_xticks(range(len(sizes)), [f"{n} blocks" for n in sizes])
    ax.set_ylim(0, 1.12)
    ax.set_ylabel("success rate")
    ax.set_title(f"Blocks world, LLM: {llm}", fontsize=10)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _in_all(config: AllConfig) -> tuple[str, ...]:
    count = "1" if config.quick else str(config.count)
    sizes = ("--sizes", "3") if config.quick else ()
    options = ("--llm", config.llm, "--count", count, *sizes, *config.jobs_argv())
    return (*options, *config.outputs("blocksworld"))


BENCHMARK = Harnessed(
    "blocksworld",
    "LLMs as blocks-world planners: SR per size",
    add_arguments,
    config_from,
    _run,
    SharedOptions(
        out="results/blocksworld",
        out_help="folder for tables and plot",
        jobs_help="tasks run in parallel processes",
    ),
    _in_all,
)

__all__ = [
    "BENCHMARK",
    "BlocksConfig",
    "Report",
    "Row",
    "TaskResult",
    "add_arguments",
    "build_llm",
    "config_from",
    "markdown_table",
    "method_label",
    "run_blocksworld",
    "run_job",
    "summarise",
]
