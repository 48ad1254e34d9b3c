"""Initial planning time vs problem size, deferred vs computed: CSV, markdown table and PNG plot.

*Deferred*: streams marked deferred (e.g. BaseMotion, Kin) are assumed at planning time and left
to the executor. *Computed* (nothing deferred; called "eager" before, a spelling still accepted
with a warning): every stream is evaluated while planning. Both use the same algorithm,
the same problems (one seed per trial) and the same limits, in one run, so their ratio is fair.
Beside the time, the table gives the median plan cost as the planner reports it (for deferred
plans it counts the optimistic values of deferred cost functions, so it is a lower bound there).

Each trial is a cached job (:mod:`llmpas.experiments.jobs`): an interrupted run resumes and a
changed setting never reuses a stale result. ``jobs > 1`` runs trials in parallel processes, which
then compete for the CPU: their timings are contended (a warning is logged and the table says how
many jobs measured its timings).
"""

from __future__ import annotations

import argparse
import logging
import statistics
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.examples import EXAMPLES, get_example
from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions, rows_of, run_trials
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    fingerprint,
    not_cacheable,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.options import MAX_EXAMPLE_SIZE, bounded_int, positive_float, positive_int
from llmpas.planning import PlannerConfig, planner_registry, solve
from llmpas.planning.quality import DEFAULT_QUALITY, QUALITIES

log = logging.getLogger(__name__)

MODES = ("deferred", "computed")
DEPRECATED_MODES = {"eager": "computed"}  # old spelling -> mode


@dataclass(frozen=True)
class BenchConfig:
    examples: tuple[str, ...] = ("mobile", "tamp2d")
    trials: int = 5
    max_time: float = 60.0
    sizes: tuple[int, ...] | None = None  # None: each example's own sizes
    out_dir: Path = Path("results/planning-time")
    algorithm: str = "focused"  # PlannerConfig.algorithm (llmpas.planning.planner_registry)
    classical: str = "fast-downward"  # PlannerConfig.classical (llmpas.planning.planner_registry)
    quality: str = "fast"  # PlannerConfig.quality
    jobs: int = 1  # parallel processes (> 1: contended timings)
    # where the trials run (local: ``jobs`` processes)
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)

    def __post_init__(self) -> None:
        if self.trials < 1:
            raise ValueError(f"trials must be >= 1, got {self.trials}")
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")
        if self.max_time <= 0:
            raise ValueError(f"max_time must be > 0, got {self.max_time}")
        if self.sizes is not None and (not self.sizes or min(self.sizes) < 1):
            raise ValueError(f"sizes must be positive integers, got {self.sizes}")
        for name in self.examples:
            get_example(name)  # raises KeyError naming the known examples


@dataclass(frozen=True)
class Trial:
    example: str
    size: int
    mode: str
    trial: int
    status: str
    total_time: float
    stream_time: float
    translate_time: float
    search_time: float
    stream_calls: int
    plan_length: int
    cost: float | None = None  # the plan's cost (None: no plan)

    @property
    def solved(self) -> bool:
        return self.status == "solved"


@dataclass(frozen=True)
class Row:
    """One line of the table: an example at one size, both modes."""

    example: str
    size: int
    median: dict[str, float | None]  # mode -> median time of solved trials (None: none solved)
    solved: dict[str, int]
    trials: int
    cost: dict[str, float | None] = field(default_factory=dict)  # mode -> median plan cost

    @property
    def ratio(self) -> float | None:
        d, e = self.median["deferred"], self.median["computed"]
        if d is None or e is None or d <= 0:
            return None
        return e / d


@dataclass(frozen=True)
class Report:
    trials: tuple[Trial, ...]
    rows: tuple[Row, ...]
    files: tuple[Path, ...] = field(default_factory=tuple)


@dataclass(frozen=True)
class Payload:
    """One job: one trial of an example at one size in one mode (picklable)."""

    example: str
    size: int
    mode: str
    trial: int
    config: BenchConfig


def planner_config(mode: str, trial: int, config: BenchConfig) -> PlannerConfig:
    if mode in DEPRECATED_MODES:
        warnings.warn(
            f"mode {mode!r} is deprecated; say {DEPRECATED_MODES[mode]!r} (nothing deferred)",
            DeprecationWarning,
            stacklevel=2,
        )
        mode = DEPRECATED_MODES[mode]
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    return PlannerConfig(
        algorithm=config.algorithm,
        classical=config.classical,
        defer=(mode == "deferred"),
        max_time=config.max_time,
        search_time=config.max_time,
        seed=trial,
        quality=config.quality,  # type: ignore[arg-type]
    )


def run_trial(example: str, size: int, mode: str, trial: int, config: BenchConfig) -> Trial:
    problem = get_example(example).make_problem(size, trial)
    result = solve(problem, planner_config(mode, trial, config))
    s = result.stats
    return Trial(
        example,
        size,
        mode,
        trial,
        result.status.value,
        s.total_time,
        s.stream_time,
        s.translate_time,
        s.search_time,
        sum(s.stream_calls.values()),
        len(result.plan) if result.plan is not None else 0,
        result.plan.cost if result.plan is not None else None,
    )


def summarise(trials: Sequence[Trial]) -> tuple[Row, ...]:
    keys = sorted({(t.example, t.size) for t in trials})
    rows = []
    for example, size in keys:
        median: dict[str, float | None] = {}
        solved: dict[str, int] = {}
        cost: dict[str, float | None] = {}
        for mode in MODES:
            ts = [t for t in trials if (t.example, t.size, t.mode) == (example, size, mode)]
            times = [t.total_time for t in ts if t.solved]
            median[mode] = statistics.median(times) if times else None
            solved[mode] = len(times)
            costs = [t.cost for t in ts if t.solved and t.cost is not None]
            cost[mode] = statistics.median(costs) if costs else None
        n = max(1, len([t for t in trials if (t.example, t.size) == (example, size)]) // 2)
        rows.append(Row(example, size, median, solved, n, cost))
    return tuple(rows)


def run_job(payload: Payload) -> dict[str, Any]:
    """Run one trial (a module-level function: it may run in another process). The result also
    records how many jobs ran in parallel while it was timed."""
    p = payload
    trial = run_trial(p.example, p.size, p.mode, p.trial, p.config)
    result = {**asdict(trial), "jobs": p.config.jobs}
    if trial.status == "crashed":  # the planner crashed: not a timing to keep
        return not_cacheable(result, "the planner crashed")
    return result


def jobs_for(config: BenchConfig) -> list[Job[Payload]]:
    """One job per (example, size, trial, mode); the key fingerprints the planner settings."""
    out = []
    for ex in config.examples:
        for size in config.sizes or get_example(ex).sizes:
            for trial in range(config.trials):
                for mode in MODES:
                    settings = asdict(planner_config(mode, trial, config))
                    digest = fingerprint([ex, size, mode, trial, settings])
                    key = f"{ex}/size{size}/{mode}/trial{trial}/{digest}"
                    out.append(Job(key, Payload(ex, size, mode, trial, config)))
    return out


def run_planning_time(config: BenchConfig, console: Console | None = None) -> Report:
    """Run (or resume) every trial not cached yet; write the CSV, table and plot."""
    console = console or Console()
    if config.jobs > 1:
        log.warning(
            "planning-time with %d parallel jobs: timings measured in parallel are contended "
            "(use --jobs 1 for timings to report)",
            config.jobs,
        )
    if config.executor.kind != "local":
        log.warning(
            "planning-time on %s: trials run side by side on the cluster's CPUs, so timings "
            "are contended (use the local executor with --jobs 1 for timings to report)",
            config.executor.kind,
        )
    results = run_trials(config, jobs_for(config), run_job, "planning-time", console)
    measured = max(int(r.get("jobs", 1)) for r in results)
    if measured > config.jobs:
        log.warning(
            "planning-time: cached timings were measured with %d parallel jobs: contended",
            measured,
        )
    trials = rows_of(Trial, results)
    rows = summarise(trials)
    files = write_outputs(trials, rows, config, measured)
    console.print(markdown_table(rows, config, measured))
    return Report(tuple(trials), rows, files)


def _fmt(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f}"


def _jobs_note(jobs: int) -> str:
    if jobs == 1:
        return "1 job: trials one at a time"
    return f"{jobs} parallel jobs: timings contended"


def markdown_table(rows: Iterable[Row], config: BenchConfig, jobs: int | None = None) -> str:
    """The table; ``jobs``: how many parallel jobs measured the timings (default
    ``config.jobs``)."""
    jobs = config.jobs if jobs is None else jobs
    lines = [
        f"Initial planning time (median of solved trials, seconds; {config.trials} trials per "
        f"size, limit {config.max_time:g} s per trial; quality {config.quality}; "
        f"{_jobs_note(jobs)}). Cost: median plan cost of the solved trials (deferred: with the "
        "optimistic values of deferred cost functions).",
        "",
        "| example | size | deferred (s) | cost | solved | computed (s) | cost | solved "
        "| computed / deferred |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        ratio = "—" if r.ratio is None else f"{r.ratio:.1f}x"
        lines.append(
            f"| {r.example} | {r.size} | {_fmt(r.median['deferred'])} | "
            f"{_fmt(r.cost.get('deferred'))} | "
            f"{r.solved['deferred']}/{r.trials} | {_fmt(r.median['computed'])} | "
            f"{_fmt(r.cost.get('computed'))} | "
            f"{r.solved['computed']}/{r.trials} | {ratio} |"
        )
    return "\n".join(lines) + "\n"


def write_outputs(
    trials: Sequence[Trial], rows: Sequence[Row], config: BenchConfig, jobs: int | None = None
) -> tuple[Path, ...]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "planning_time.csv"
    write_csv(csv_path, [asdict(t) for t in trials])
    md_path = out / "planning_time.md"
    atomic_write(md_path, markdown_table(rows, config, jobs))
    png_path = out / "planning_time.png"
    plot(trials, rows, config, png_path)
    return (csv_path, md_path, png_path)


def plot(trials: Sequence[Trial], rows: Sequence[Row], config: BenchConfig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    examples = sorted({r.example for r in rows})
    fig, axes = plt.subplots(1, len(examples), figsize=(5.5 * len(examples), 4.2), squeeze=False)
    colors = {"deferred": "tab:blue", "computed": "tab:red"}
    for ax, ex in zip(axes[0], examples, strict=True):
        for mode in MODES:
            pts = [t for t in trials if t.example == ex and t.mode == mode]
            ok = [t for t in pts if t.solved]
            bad = [t for t in pts if not t.solved]
            ax.scatter(
                [t.size for t in ok],
                [t.total_time for t in ok],
                s=12,
                alpha=0.35,
                color=colors[mode],
            )
            ax.scatter(
                [t.size for t in bad],
                [config.max_time for _ in bad],
                marker="x",
                s=30,
                color=colors[mode],
            )
            med = [(r.size, r.median[mode]) for r in rows if r.example == ex]
            xs = [s for s, m in med if m is not None]
            ys = [m for _, m in med if m is not None]
            ax.plot(xs, ys, "-o", color=colors[mode], label=f"{mode} (median of solved)")
        ax.axhline(config.max_time, color="gray", ls=":", lw=1)
        ax.set_yscale("log")
        ax.set_xlabel("problem size (objects)")
        ax.set_ylabel("initial planning time (s)")
        ax.set_title(f"{ex}: x = unsolved within {config.max_time:g} s")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


# ------------------------------------------------------------------------------------ CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench planning-time``."""
    p.add_argument("--examples", nargs="+", default=["mobile", "tamp2d"])
    p.add_argument(
        "--sizes", nargs="+", type=bounded_int(1, MAX_EXAMPLE_SIZE), help="the example's sizes"
    )
    p.add_argument("--trials", type=positive_int, default=5)
    p.add_argument("--max-time", type=positive_float, default=60.0, help="seconds per planning run")
    p.add_argument(
        "--quality", choices=tuple(QUALITIES), default=DEFAULT_QUALITY, help="plan quality"
    )
    p.add_argument(
        "--algorithm",
        choices=planner_registry.algorithm_names(),
        default=planner_registry.DEFAULT_ALGORITHM,
    )
    p.add_argument(
        "--classical",
        choices=planner_registry.classical_names(),
        default=planner_registry.DEFAULT_CLASSICAL,
    )


def config_from(args: argparse.Namespace, shared: Shared) -> BenchConfig:
    """The config of ``llmpas bench planning-time``'s options."""
    unknown = [e for e in args.examples if e not in EXAMPLES]
    if unknown:
        known = ", ".join(sorted(EXAMPLES))
        raise ValueError(f"--examples: unknown example {unknown[0]!r}; examples: {known}")
    config = BenchConfig(
        examples=tuple(args.examples),
        trials=args.trials,
        max_time=args.max_time,
        sizes=tuple(args.sizes) if args.sizes else None,
        out_dir=shared.out_dir,
        algorithm=args.algorithm,
        classical=args.classical,
        quality=args.quality,
        jobs=shared.jobs,
        executor=shared.executor,
    )
    return config


def _run(config: BenchConfig, console: Console) -> tuple[Path, ...]:
    return run_planning_time(config, console).files


def _in_all(config: AllConfig) -> tuple[str, ...]:
    # its trials run one at a time: timings measured in parallel are contended
    quick = ("--examples", "tamp2d", "--sizes", "2", "3", "--trials", "1") if config.quick else ()
    return (*quick, *config.outputs("planning-time"))


BENCHMARK = Harnessed(
    "planning-time",
    "initial planning time vs size, deferred vs computed",
    add_arguments,
    config_from,
    _run,
    SharedOptions(
        out="results/planning-time",
        jobs_help="parallel processes (> 1: timings are contended; results cached under OUT/cache)",
        jobs_type=positive_int,
    ),
    _in_all,
)
