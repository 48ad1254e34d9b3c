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

Each (method, task, sample) is a cached job (:mod:`llmpas.experiments.jobs`): an interrupted run
resumes, ``jobs`` runs them in parallel processes. Writes ``prompting.md`` (Table II and the extra
metrics), ``prompting.csv`` (one row per method and anomaly type), ``prompting.json`` (the same
cells with the run's settings), ``prompting_samples.csv`` (one row per sample) and
``prompting.png``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import statistics
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.catalog import oracle_for
from llmpas.experiments.benchmarks import AllConfig, Bench
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    add_executor_arguments,
    add_llm_argument,
    backend,
    cache_file,
    executor_from_args,
    fingerprint,
    llm_resources,
    run_jobs,
)
from llmpas.experiments.suite import (
    HALVES,
    SUITE_DIR,
    Category,
    SuiteTask,
    development_half,
    judge,
    load_suite,
    load_task,
    parse_task,
)
from llmpas.experiments.worlds import LoopConfig
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.planning import PlannerConfig
from llmpas.reasoning.assists import PROTOCOLS, Assists, ablation, parse_assists
from llmpas.reasoning.backends.registry import BACKENDS, choices
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import (
    DECODINGS,
    METHODS,
    PAPER_METHODS,
    REGISTRY,
    SCORINGS,
    MethodConfig,
    controls,
    method_names,
)
from llmpas.reasoning.replan import REPLAN, Replan
from llmpas.reasoning.truth_oracle import ORACLE
from llmpas.system import LLMFor, LoopResult, SweepBudget
from llmpas.worlds.api import RunOptions

log = logging.getLogger(__name__)

UPPER_BOUND = "upper bound"
BASELINE = "no reasoning"
REPLAN_VERSION = "replan-2"  # part of the replan row's cache keys: bump when its answers change


@dataclass(frozen=True)
class PromptingConfig:
    """One run of the experiment.

    ``llm``: ``oracle`` | ``replay:DIR`` | ``openai:MODEL[@URL]`` | ``llama-cpp[:PATH]`` (as
    ``llmpas run --llm``); ``record``: a cassette folder the answers are recorded into.
    ``methods``: prompting methods (of :data:`llmpas.reasoning.methods.METHODS`); ``oracle``
    adds the upper-bound row, ``replan`` the no-reasoning baseline row (and the lifts).
    ``tasks``: only these task names (default: the whole suite); ``measures_llm``: only the
    tasks marked ``measures_llm`` (the suite that measures the LLM).
    """

    llm: str = "llama-cpp"
    methods: tuple[str, ...] = METHODS
    oracle: bool = True
    replan: bool = True
    measures_llm: bool = False
    half: str = ""  # development | rest: only that half of the tasks (suite.development_half)
    samples: int = 3
    temperature: float = 0.7
    seed: int = 0
    decoding: str = "grammar"
    repairs: int = 2
    max_rounds: int = 3
    max_tokens: int = 256
    max_time: float = 600.0  # planner safety net per plan (counted limits decide)
    suite: Path = SUITE_DIR
    tasks: tuple[str, ...] | None = None
    record: Path | None = None
    jobs: int = 1
    out_dir: Path = Path("results/prompting")
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)
    keep_runs: bool = False  # each run's folder (loop.json, index.html) under out_dir/runs
    protocols: tuple[str, ...] = ("assisted",)  # paper | assisted | assists joined by "+"
    ablation: bool = False  # also: no assist, each assist alone, all (the methods' rows)
    votes: int = 1  # self-consistency: sampled answers per consultation (1: off)
    # places one object-loss consultation's sweep searches at most (1: one place a
    # consultation, the loop before #35's sweeps)
    sweep_places: int = SweepBudget().places
    scoring: str = "mean"  # how the choosing methods score candidates (choose.Scoring)

    def __post_init__(self) -> None:
        if self.scoring not in SCORINGS:
            raise ValueError(f"scoring must be one of {', '.join(SCORINGS)}; got {self.scoring!r}")
        if not self.protocols:
            raise ValueError("protocols: give at least one (paper, assisted)")
        for spec in self.protocols:
            parse_assists(spec)  # ValueError naming an unknown assist
        if not 1 <= self.votes <= 16:
            raise ValueError(f"votes must be in [1, 16], got {self.votes}")
        if self.half not in ("", *HALVES):
            raise ValueError(f"half must be one of {', '.join(HALVES)}; got {self.half!r}")
        known = method_names()
        bad = [m for m in self.methods if m not in known]
        if bad:
            raise ValueError(f"unknown method {bad[0]!r}; methods: {', '.join(known)}")
        if len(set(self.methods)) != len(self.methods):
            raise ValueError("a method is listed twice")
        if not self.methods and not self.oracle and not self.replan:
            raise ValueError("nothing to run: give methods or keep the oracle or replan row")
        if self.samples < 1:
            raise ValueError(f"samples must be >= 1, got {self.samples}")
        if not 0.0 <= self.temperature <= 2.0:
            raise ValueError(f"temperature must be in [0, 2], got {self.temperature}")
        if self.decoding not in DECODINGS:
            raise ValueError(f"decoding must be one of {', '.join(DECODINGS)}")
        if self.repairs < 0:
            raise ValueError(f"repairs must be >= 0, got {self.repairs}")
        if self.max_rounds < 1:
            raise ValueError(f"max_rounds must be >= 1, got {self.max_rounds}")
        if self.sweep_places < 1:
            raise ValueError(f"sweep_places must be >= 1, got {self.sweep_places}")
        if self.max_tokens < 1:
            raise ValueError(f"max_tokens must be >= 1, got {self.max_tokens}")
        if self.max_time <= 0:
            raise ValueError(f"max_time must be > 0, got {self.max_time}")
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")
        if self.tasks is not None and not self.tasks:
            raise ValueError("tasks: give at least one task name (or None for all)")
        if not self.llm.strip():
            raise ValueError(f"llm: give a backend ({choices(('oracle', *BACKENDS))})")


@dataclass(frozen=True)
class Payload:
    """One job: run ``method`` (``oracle``: the upper bound; ``replan``: the no-reasoning
    baseline) on one task file, sample ``sample``.
    The file's content travels with the job (a cluster's workers need not have the file)."""

    task_file: str
    method: str
    sample: int
    llm: str  # the backend spec ("oracle" / "replan" for those rows)
    record: str | None
    loop: LoopConfig
    task_data: bytes | None = None  # the task file's content (None: read ``task_file``)
    keep: str | None = None  # the folder this run is kept in
    row: str = ""  # the table's row ("": ``method``)


# ------------------------------------------------------------------------------- backends


def build_llm(spec: str, record: str | None = None) -> LLM | LLMFor:
    """The backend for ``spec`` (``oracle``: the oracle factory), built once per process (a local
    model is loaded once, not per job: :func:`~llmpas.experiments.jobs.backend`). ValueError
    for a bad spec."""
    if spec == ORACLE:
        return oracle_for("household")
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
    if payload.task_data is None:
        task = load_task(payload.task_file)
    else:
        task = parse_task(payload.task_data, payload.task_file)
    llm = (
        Replan(task.scenario.goal, payload.loop.method.method)
        if payload.method == REPLAN
        else build_llm(payload.llm, payload.record)
    )
    j = judge(task, llm, payload.loop, _keeper(payload, task) if payload.keep else None)
    log.info("%s %s #%d: %s", payload.method, task.name, payload.sample, j.verdict.value)
    row = payload.row or payload.method
    protocol = payload.loop.assists.label
    return {
        "method": row,
        "protocol": protocol,
        "sample": payload.sample,
        "l_gt": task.l_gt,
        **j.to_json(),
    }


def _keeper(payload: Payload, task: SuiteTask) -> Callable[[LoopResult], object]:
    """Saves a run's ``loop.json`` and its web report into ``payload.keep``."""

    def keep(result: LoopResult) -> None:
        from llmpas.reporting import build_report

        folder = Path(str(payload.keep))
        result.save(folder / "loop.json")
        about = {"scenario": task.name, "world": "household", "llm": payload.llm}
        build_report(folder, about | {"method": payload.method, "task": task.scenario.goal})

    return keep


def run_folder(config: PromptingConfig, key: str) -> Path:
    """Where the run of job ``key`` is kept (with ``keep_runs``)."""
    path = cache_file(config.out_dir / "runs", key)
    return path.with_name(path.stem)


# ---------------------------------------------------------------------------------- summary


@dataclass(frozen=True)
class Cell:
    """One method on one anomaly type (or ``all``)."""

    method: str
    category: str
    tasks: int
    samples: int
    sr: float
    aspl: float
    syntax_error_rate: float | None  # None: no goal answers were read (e.g. none asked)
    repairs: float  # per sample
    tokens: float  # per sample
    latency: float  # seconds per sample
    completion: float  # share of samples the loop reported done
    false_done: int  # samples the loop believed done but the truth disagreed
    first_effective: float | None = None  # share of first proposals that are effective
    lift: float | None = None  # SR minus the replan row's SR (None: no replan row, a baseline)
    sr_low: float = 0.0  # 95 % Wilson interval of the pooled samples' success rate
    sr_high: float = 1.0


def _cell(method: str, category: str, records: Sequence[dict[str, Any]]) -> Cell:
    by_task: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        by_task.setdefault(str(r["task"]), []).append(r)
    srs, terms = [], []
    for rs in by_task.values():
        ok = [r for r in rs if r["success"]]
        sr = len(ok) / len(rs)
        srs.append(sr)
        if ok:
            mean_len = statistics.fmean(float(r["resolution_length"]) for r in ok)
            terms.append(mean_len / float(rs[0]["l_gt"]) * sr)
        else:
            terms.append(0.0)
    n = len(by_task)
    answers = sum(int(r["answers"]) for r in records)
    count = len(records)
    judged = [bool(r["first_effective"]) for r in records if r.get("first_effective") is not None]
    low, high = wilson(sum(bool(r["success"]) for r in records), count)
    return Cell(
        method=method,
        category=category,
        tasks=n,
        samples=count,
        sr=sum(srs) / n,
        aspl=sum(terms) / n,
        syntax_error_rate=(
            sum(int(r["syntax_errors"]) for r in records) / answers if answers else None
        ),
        repairs=sum(int(r["repairs"]) for r in records) / count,
        tokens=sum(int(r["tokens"]) for r in records) / count,
        latency=sum(float(r["latency"]) for r in records) / count,
        completion=sum(bool(r["completed"]) for r in records) / count,
        false_done=sum(r["verdict"] == "false-done" for r in records),
        first_effective=sum(judged) / len(judged) if judged else None,
        sr_low=low,
        sr_high=high,
    )


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95 % Wilson score interval of ``successes`` out of ``n`` (samples pooled over
    tasks; (0, 1) for n = 0)."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * ((p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def summarise(records: Sequence[dict[str, Any]], methods: Sequence[str]) -> tuple[Cell, ...]:
    """One cell per method and anomaly type present, plus ``all`` per method; each method's
    cell has its lift over the replan row's cell of the same type (when there is one)."""
    cells = []
    for method in methods:
        mine = [r for r in records if r["method"] == method]
        if not mine:
            continue
        for cat in Category:
            rs = [r for r in mine if r["category"] == cat.value]
            if rs:
                cells.append(_cell(method, cat.value, rs))
        cells.append(_cell(method, "all", mine))
    base = {c.category: c.sr for c in cells if c.method == REPLAN}
    return tuple(
        replace(c, lift=c.sr - base[c.category])
        if c.method not in (ORACLE, REPLAN) and c.category in base
        else c
        for c in cells
    )


def method_label(method: str, llm: str) -> str:
    if method == ORACLE:
        return f"oracle ({UPPER_BOUND})"
    if method == REPLAN:
        return f"replan ({BASELINE}: the task restated)"
    if llm == ORACLE:
        return f"{method} with the oracle LLM ({UPPER_BOUND})"
    return method


def _f(x: float | None, digits: int = 2) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def _signed(x: float | None) -> str:
    return "—" if x is None else f"{x:+.2f}"


def markdown_table(cells: Sequence[Cell], config: PromptingConfig) -> str:
    methods = list(dict.fromkeys(c.method for c in cells))
    cats = [c for c in Category if any(x.category == c.value for x in cells)]
    get = {(c.method, c.category): c for c in cells}
    fixed = " and ".join(
        name for name, on in ((ORACLE, config.oracle), (REPLAN, config.replan)) if on
    )
    sampling = (
        f"{config.samples} sample(s) per task at temperature {config.temperature:g}"
        + (f", {fixed}: 1" if fixed else "")
        if config.methods
        else "1 sample per task"
    )
    lines = [
        f"Prompting methods on the household anomaly suite (LLM: {config.llm}; {sampling}; "
        f"at most {config.max_rounds} LLM rounds per run). "
        "SR: success rate; ASPL = (1/n) Σ (L̄_i / L_gt,i) × SR_i; "
        "1st eff.: share of first proposals that entail an effective goal set of the task.",
        "",
        "| Method | "
        + " | ".join(f"{c.title} SR | {c.title} ASPL | {c.title} 1st eff." for c in cats)
        + " |",
        "|---|" + "---:|---:|---:|" * len(cats),
    ]
    for m in methods:
        row = [method_label(m, config.llm)]
        for cat in cats:
            cell = get.get((m, cat.value))
            row += [_f(cell.sr), _f(cell.aspl), _f(cell.first_effective)] if cell else ["—"] * 3
        lines.append("| " + " | ".join(row) + " |")
    lifted = [m for m in methods if get.get((m, "all")) and get[(m, "all")].lift is not None]
    if lifted:
        lines += [
            "",
            "Lift over replan (SR minus the replan row's SR; replan answers every goal request "
            "with the task goal, so a lift near 0 means the planner, not the LLM, resolved the "
            "anomalies):",
            "",
            "| Method | " + " | ".join(c.title for c in cats) + " | all |",
            "|---|" + "---:|" * (len(cats) + 1),
        ]
        for m in lifted:
            row = [method_label(m, config.llm)]
            row += [_signed(get[(m, c.value)].lift) if (m, c.value) in get else "—" for c in cats]
            row.append(_signed(get[(m, "all")].lift))
            lines.append("| " + " | ".join(row) + " |")
    counts = ", ".join(
        f"{get[(methods[0], c.value)].tasks} {c.value}"
        for c in cats
        if (methods[0], c.value) in get
    )
    lines += [
        "",
        f"Per sample, over all tasks (n = {counts}):",
        "",
        "| Method | SR | SR 95 % CI | ASPL | 1st eff. | lift | syntax-error rate | repairs "
        "| tokens | LLM latency (s) | loop completion | false done |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for m in methods:
        c = get[(m, "all")]
        lines.append(
            f"| {method_label(m, config.llm)} | {_f(c.sr)} | {_f(c.sr_low)}–{_f(c.sr_high)} | "
            f"{_f(c.aspl)} | "
            f"{_f(c.first_effective)} | {_signed(c.lift)} | "
            f"{_f(c.syntax_error_rate)} | {c.repairs:.2f} | {c.tokens:.0f} | {c.latency:.2f} | "
            f"{c.completion:.2f} | {c.false_done} |"
        )
    lines += control_lines(methods, config)
    lines += ablation_lines(cells, config)
    return "\n".join(lines) + "\n"


def control_lines(methods: Sequence[str], config: PromptingConfig) -> list[str]:
    """Which row each method's row is compared with (a claim that the model helped holds only
    against its control on the same tasks and seeds), and how candidates were scored."""
    named = [m for m in methods if m in REGISTRY]
    if not named:
        return []
    lines = ["", "Each row is compared with (its control first):", ""]
    lines += ["| Method | compared with |", "|---|---|"]
    for m in named:
        present = [c for c in controls(m) if c in methods or (c == REPLAN and config.replan)]
        shown = ", ".join(f"{c}" + ("" if c in present else " (not run here)") for c in controls(m))
        lines.append(f"| {m} | {shown} |")
    if any(REGISTRY[m].chooser in ("model", "prior") for m in named):
        lines += ["", f"Candidates scored by `{config.scoring}` (`--scoring`)."]
    return lines


def ablation_lines(cells: Sequence[Cell], config: PromptingConfig) -> list[str]:
    """SR over all tasks (with its interval) of each method under each variant of the assists,
    when there is more than one: what each assist adds, alone and together."""
    shown = variants(config)
    if len(shown) < 2 or not config.methods:
        return []
    get = {(c.method, c.category): c for c in cells}
    lines = [
        "",
        "Assists (SR over all tasks, 95 % interval; paper: the goals parsed and syntax-checked "
        "only; assisted: every assist):",
        "",
        "| Method | " + " | ".join(a.label for a in shown) + " |",
        "|---|" + "---:|" * len(shown),
    ]
    for m in config.methods:
        row = [m]
        for a in shown:
            c = get.get((row_id(m, a), "all"))
            row.append(f"{c.sr:.2f} ({c.sr_low:.2f}–{c.sr_high:.2f})" if c else "—")
        lines.append("| " + " | ".join(row) + " |")
    return lines


# -------------------------------------------------------------------------------------- run


@dataclass(frozen=True)
class Report:
    records: tuple[dict[str, Any], ...]
    cells: tuple[Cell, ...]
    files: tuple[Path, ...] = field(default=())


def variants(config: PromptingConfig) -> tuple[Assists, ...]:
    """The assists the methods run with, in order (each protocol, then the ablation's)."""
    out = [parse_assists(p) for p in config.protocols]
    out += list(ablation()) if config.ablation else []
    return tuple(dict.fromkeys(out))


def row_id(method: str, assists: Assists) -> str:
    """A method's row under ``assists``: the method's name in the assisted protocol (today's
    loop), else ``method [label]``."""
    return method if assists == PROTOCOLS["assisted"] else f"{method} [{assists.label}]"


def plan_rows(config: PromptingConfig) -> list[tuple[str, str, Assists]]:
    """(row, method, assists) of the table, in order: the oracle, replan, then the methods
    under each variant."""
    fixed = [
        (m, m, Assists()) for m, on in ((ORACLE, config.oracle), (REPLAN, config.replan)) if on
    ]
    methods = [(row_id(m, a), m, a) for a in variants(config) for m in config.methods]
    return fixed + methods


def rows(config: PromptingConfig) -> list[str]:
    """The table's rows, in order: the oracle, replan, then the methods (per variant)."""
    return [row for row, _, _ in plan_rows(config)]


def _loop_key(loop: LoopConfig) -> dict[str, Any]:
    """The loop's config as its jobs' cache keys hold it: the method's ``scoring`` and
    ``task`` left out at their defaults, so that the runs cached before they existed are kept."""
    data = asdict(loop)
    method = data["method"]
    for name, default in (("scoring", "mean"), ("task", "")):
        if method.get(name) == default:
            del method[name]
    return data


def jobs_for(config: PromptingConfig, tasks: Sequence[SuiteTask]) -> list[Job[Payload]]:
    out = []
    data = {t.source: _content(t) for t in tasks}
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
                payload = Payload(t.source, method, k, llm, record, loop, data[t.source], keep, row)
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
    tasks = load_suite(config.suite, config.tasks)
    if config.measures_llm:
        tasks = tuple(t for t in tasks if t.measures_llm)
        if not tasks:
            raise ValueError(f"{config.suite}: no task is marked measures_llm")
    if config.half:
        development = development_half(load_suite(config.suite))  # of the whole suite
        keep = config.half == "development"
        tasks = tuple(t for t in tasks if (t.name in development) == keep)
    jobs = jobs_for(config, tasks)
    if (
        config.methods
        and config.llm != ORACLE
        and config.jobs == 1
        and config.executor.kind == "local"
    ):
        # fail early on a bad spec (with --jobs N each worker process builds its own backend:
        # a local model is then loaded N times)
        build_llm(config.llm, None if config.record is None else str(config.record))
    records = run_jobs(
        jobs,
        run_job,
        config.out_dir / "cache",
        workers=config.jobs,
        description="prompting",
        console=console,
        executor=config.executor,
    )
    cells = summarise(records, rows(config))
    files = write_outputs(records, cells, config)
    console.print(markdown_table(cells, config), soft_wrap=True, highlight=False, markup=False)
    return Report(tuple(records), cells, files)


def write_outputs(
    records: Sequence[dict[str, Any]], cells: Sequence[Cell], config: PromptingConfig
) -> tuple[Path, ...]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    md = atomic_write(out / "prompting.md", markdown_table(cells, config))
    summary = write_csv(
        out / "prompting.csv",
        [{**asdict(c), "label": method_label(c.method, config.llm)} for c in cells],
    )
    samples = write_csv(
        out / "prompting_samples.csv", [{k: v for k, v in r.items() if k != "key"} for r in records]
    )
    about = {
        "llm": config.llm,
        "methods": list(config.methods),
        "oracle": config.oracle,
        "replan": config.replan,
        "measures_llm": config.measures_llm,
        "protocols": [a.label for a in variants(config)],
        "votes": config.votes,
        "samples": config.samples,
        "temperature": config.temperature,
        "max_rounds": config.max_rounds,
        "tasks": sorted({str(r["task"]) for r in records}),
    }
    table = [{**asdict(c), "label": method_label(c.method, config.llm)} for c in cells]
    js = atomic_write(
        out / "prompting.json", json.dumps({"config": about, "cells": table}, indent=2) + "\n"
    )
    png = out / "prompting.png"
    plot(cells, config, png)
    from llmpas.experiments.prompting_page import write_page

    page = write_page(records, cells, config)
    return (md, summary, js, samples, png, page)


def plot(cells: Sequence[Cell], config: PromptingConfig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(dict.fromkeys(c.method for c in cells))
    cats = [c for c in Category if any(x.category == c.value for x in cells)]
    get = {(c.method, c.category): c for c in cells}
    width = 0.8 / max(1, len(methods))
    fig, axes = plt.subplots(1, 2, figsize=(4.0 + 1.2 * len(cats) * max(1, len(methods)), 5.0))
    for ax, metric, label in zip(axes, ("sr", "aspl"), ("SR", "ASPL"), strict=True):
        top = 0.0
        for i, m in enumerate(methods):
            xs = [j + (i - (len(methods) - 1) / 2) * width for j in range(len(cats))]
            ys = [
                float(getattr(get[(m, c.value)], metric)) if (m, c.value) in get else 0.0
                for c in cats
            ]
            top = max(top, *ys)
            name = method_label(m, config.llm)
            bars = ax.bar(
                xs, ys, width * 0.95, label=name, hatch="//" if UPPER_BOUND in name else None
            )
            ax.bar_label(bars, labels=[f"{y:.2f}" for y in ys], fontsize=7, padding=1)
        ax.set_xticks(range(len(cats)), [c.title for c in cats])
        ax.set_ylim(0, max(1.12, top * 1.15))
        ax.set_ylabel(label)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_title(f"Success rate (LLM: {config.llm})", fontsize=10)
    axes[1].set_title("ASPL = mean (L̄ / L_gt) × SR", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=min(4, len(methods)))
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    save_figure(fig, path)
    plt.close(fig)


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
    p.add_argument("--jobs", type=int, default=1, help="samples run in parallel processes")
    p.add_argument("--out", default="results/prompting", help="folder for tables, plot, cache")
    p.add_argument(
        "--scoring",
        default="mean",
        choices=SCORINGS,
        help="how flp-choose and prior score candidates: mean, diff (the tokens where they "
        "differ), pmi (against the prompt without the evidence); -words: as plain words",
    )
    add_executor_arguments(p)
    p.add_argument(
        "--keep-runs",
        action="store_true",
        help="keep every run (OUT/runs/..., linked from index.html)",
    )


def config_from_args(args: argparse.Namespace) -> PromptingConfig:
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
        jobs=args.jobs,
        out_dir=Path(args.out),
        executor=executor_from_args(args),
        keep_runs=getattr(args, "keep_runs", False),
        protocols=tuple(getattr(args, "protocol", None) or ("assisted",)),
        ablation=getattr(args, "assists", False),
        votes=getattr(args, "votes", 1),
        scoring=getattr(args, "scoring", "mean"),
    )


def command(args: argparse.Namespace, console: Console) -> int:
    """``llmpas bench prompting``; user errors are ValueError / LLMError with one line."""
    report = run_prompting(config_from_args(args), console)
    console.print(f"wrote {', '.join(str(p) for p in report.files)}")
    return 0


QUICK_TASKS = ("ol01-table2", "ab06-sink-mug", "sc06-apple-frozen-stove")  # bench all --quick


def _in_all(config: AllConfig) -> tuple[str, ...]:
    methods = "none" if config.llm == ORACLE else "all"  # oracle: its row only
    samples = "1" if config.quick else str(config.samples)
    tasks = ("--tasks", *QUICK_TASKS) if config.quick else ()
    options = ("--llm", config.llm, "--methods", methods, "--samples", samples, *tasks)
    return (*options, *config.jobs_argv(), *config.outputs("prompting"))


BENCHMARK = Bench(
    "prompting",
    "prompting methods on the household anomaly suite",
    add_arguments,
    command,
    _in_all,
)

__all__ = [
    "BENCHMARK",
    "ORACLE",
    "QUICK_TASKS",
    "REPLAN",
    "Cell",
    "Payload",
    "PromptingConfig",
    "Report",
    "add_arguments",
    "build_llm",
    "command",
    "jobs_for",
    "loop_config",
    "markdown_table",
    "rows",
    "run_job",
    "run_prompting",
    "summarise",
]
