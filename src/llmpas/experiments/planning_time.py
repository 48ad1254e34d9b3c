"""Initial planning time vs problem size, deferred vs eager: CSV, markdown table and PNG plot.

*Deferred*: streams marked deferred (e.g. BaseMotion, Kin) are assumed at planning time and left
to the executor. *Eager*: every stream is evaluated while planning. Both use the same algorithm,
the same problems (one seed per trial) and the same limits, in one run, so their ratio is fair.
"""

from __future__ import annotations

import statistics
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from llmpas.examples import get_example
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.planning import PlannerConfig, solve

MODES = ("deferred", "eager")


@dataclass(frozen=True)
class BenchConfig:
    examples: tuple[str, ...] = ("mobile", "tamp2d")
    trials: int = 5
    max_time: float = 60.0
    sizes: tuple[int, ...] | None = None  # None: each example's own sizes
    out_dir: Path = Path("results/planning-time")
    algorithm: str = "focused"

    def __post_init__(self) -> None:
        if self.trials < 1:
            raise ValueError(f"trials must be >= 1, got {self.trials}")
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

    @property
    def ratio(self) -> float | None:
        d, e = self.median["deferred"], self.median["eager"]
        if d is None or e is None or d <= 0:
            return None
        return e / d


@dataclass(frozen=True)
class Report:
    trials: tuple[Trial, ...]
    rows: tuple[Row, ...]
    files: tuple[Path, ...] = field(default_factory=tuple)


def run_trial(example: str, size: int, mode: str, trial: int, config: BenchConfig) -> Trial:
    problem = get_example(example).make_problem(size, trial)
    result = solve(
        problem,
        PlannerConfig(
            algorithm=config.algorithm,  # type: ignore[arg-type]
            defer=(mode == "deferred"),
            max_time=config.max_time,
            search_time=config.max_time,
            seed=trial,
        ),
    )
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
    )


def summarise(trials: Sequence[Trial]) -> tuple[Row, ...]:
    keys = sorted({(t.example, t.size) for t in trials})
    rows = []
    for example, size in keys:
        median: dict[str, float | None] = {}
        solved: dict[str, int] = {}
        for mode in MODES:
            ts = [t for t in trials if (t.example, t.size, t.mode) == (example, size, mode)]
            times = [t.total_time for t in ts if t.solved]
            median[mode] = statistics.median(times) if times else None
            solved[mode] = len(times)
        n = max(1, len([t for t in trials if (t.example, t.size) == (example, size)]) // 2)
        rows.append(Row(example, size, median, solved, n))
    return tuple(rows)


def run_planning_time(config: BenchConfig, console: Console | None = None) -> Report:
    console = console or Console()
    jobs = [
        (ex, size, mode, trial)
        for ex in config.examples
        for size in (config.sizes or get_example(ex).sizes)
        for trial in range(config.trials)
        for mode in MODES
    ]
    trials: list[Trial] = []
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console, transient=False) as progress:
        task = progress.add_task("planning-time", total=len(jobs))
        for ex, size, mode, trial in jobs:
            progress.update(task, description=f"{ex} size {size} {mode} trial {trial + 1}")
            trials.append(run_trial(ex, size, mode, trial, config))
            progress.advance(task)
    rows = summarise(trials)
    files = write_outputs(trials, rows, config)
    console.print(markdown_table(rows, config))
    return Report(tuple(trials), rows, files)


def _fmt(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f}"


def markdown_table(rows: Iterable[Row], config: BenchConfig) -> str:
    lines = [
        f"Initial planning time (median of solved trials, seconds; {config.trials} trials per "
        f"size, limit {config.max_time:g} s per trial)",
        "",
        "| example | size | deferred (s) | solved | eager (s) | solved | eager / deferred |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        ratio = "—" if r.ratio is None else f"{r.ratio:.1f}x"
        lines.append(
            f"| {r.example} | {r.size} | {_fmt(r.median['deferred'])} | "
            f"{r.solved['deferred']}/{r.trials} | {_fmt(r.median['eager'])} | "
            f"{r.solved['eager']}/{r.trials} | {ratio} |"
        )
    return "\n".join(lines) + "\n"


def write_outputs(
    trials: Sequence[Trial], rows: Sequence[Row], config: BenchConfig
) -> tuple[Path, ...]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "planning_time.csv"
    write_csv(csv_path, [asdict(t) for t in trials])
    md_path = out / "planning_time.md"
    atomic_write(md_path, markdown_table(rows, config))
    png_path = out / "planning_time.png"
    plot(trials, rows, config, png_path)
    return (csv_path, md_path, png_path)


def plot(trials: Sequence[Trial], rows: Sequence[Row], config: BenchConfig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    examples = sorted({r.example for r in rows})
    fig, axes = plt.subplots(1, len(examples), figsize=(5.5 * len(examples), 4.2), squeeze=False)
    colors = {"deferred": "tab:blue", "eager": "tab:red"}
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
