"""``llmpas bench tamp``: CPU time of planning on the pds-tamp2d families, streams computed vs
IK and motion deferred; every plan validated; CSV, Markdown table and PNG plot.

*computed*: every stream is evaluated while planning (``defer=False``). *deferred*: IK and
motion are assumed while planning and evaluated afterwards, by the validator, as an executor
would. Both modes plan the same seeded problems under the same limits in one run.

Each trial runs in its own process (spawned, so nothing is inherited from the parent) under an
address-space limit; its CPU time is the planning's own (``getrusage`` of the process and of its
children, the Fast Downward searches), measured around the planner call only; its wall time
too. A trial that outlives the limit by ``KILL_GRACE`` seconds is killed and counts as unsolved.
A solved trial counts as solved only when its plan validates (:mod:`~llmpas.examples.
tamp2d_pds.validate`). Trials are cached jobs (:mod:`llmpas.experiments.jobs`): an interrupted
run resumes. Sizes run in increasing order; a (family, mode) that solves no trial at one size is
not run at larger sizes (``--keep-going`` runs them anyway).

*Plan quality*: each mode runs with every quality of ``--qualities`` (``fast``, ``anytime``,
``optimal``; :mod:`llmpas.planning.quality`); a column is named by its mode, followed by
``+QUALITY`` unless the quality is ``fast``. Every solved trial's **cost** is the validator's:
the plan replayed on the real values (deferred streams evaluated). With ``anytime``, each
trial's cheaper plans (CPU s, cost) are kept, and ``tamp-anytime.png`` plots cost over CPU time
for one N.

``--pddlstream-files DIR`` plans PDDLStream's own ``continuous_tamp`` domain and stream files
(read from DIR, not shipped) with the streams and families of :mod:`.pds_files` instead.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import multiprocessing
import os
import resource
import signal
import statistics
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from importlib.resources import files
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.examples.tamp2d_pds import FAMILIES, make_problem
from llmpas.examples.tamp2d_pds.pds2d_plan_check import validate
from llmpas.experiments import pds_files
from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions, rows_of, run_trials
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    fingerprint,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.planning import PlannerConfig, solve
from llmpas.planning.quality import QUALITIES

log = logging.getLogger(__name__)

MODES = ("computed", "deferred")
KILL_GRACE = 15.0  # seconds past max_time before a trial's process is killed
#: PDDLStream's adaptive algorithm on its own 2-D examples, median CPU seconds (None: unsolved
#: within its 10 s planner limit); measured separately, see shared/notes/pddlstream-reference.md.
REFERENCE: dict[str, dict[int, float | None]] = {
    "mirror": {1: 0.09, 2: 0.15, 3: 0.31, 4: 0.84, 5: 4.7, 6: None, 7: None},
    "packed": {1: 0.10, 2: 0.75, 3: 3.2, 4: 5.2, 5: 41.0},
}
REFERENCE_LABEL = "PDDLStream adaptive, measured separately (shared/notes), not by this command"


@dataclass(frozen=True)
class TampBenchConfig:
    families: tuple[str, ...] = FAMILIES
    sizes: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7, 8)
    trials: int = 3
    max_time: float = 60.0
    jobs: int = 1  # parallel trials (> 1: contended)
    memory_mb: int = 3072  # address-space limit of a trial's process
    keep_going: bool = False  # run larger sizes after a size with no solved trial
    share: bool = False  # PlannerConfig.share_placeholders
    out_dir: Path = Path("results/tamp")
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)
    modes: tuple[str, ...] = MODES
    qualities: tuple[str, ...] = ("fast",)
    files: Path | None = None  # PDDLStream's continuous_tamp folder (see pds_files)
    anytime_size: int | None = None  # N of the anytime plot (None: the largest solved)

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(label(m, q) for m in self.modes for q in self.qualities)

    def __post_init__(self) -> None:
        bad = [m for m in self.modes if m not in MODES] + [
            q for q in self.qualities if q not in QUALITIES
        ]
        if bad or not self.modes or not self.qualities:
            raise ValueError(
                f"unknown mode or quality {bad[:1]}; modes: {', '.join(MODES)}; "
                f"qualities: {', '.join(QUALITIES)}"
            )
        if self.files is not None:
            pds_files.check_files(self.files)
        unknown = [f for f in self.families if f not in FAMILIES]
        if unknown or not self.families:
            raise ValueError(f"unknown family {unknown[:1]}; families are {', '.join(FAMILIES)}")
        if not self.sizes or min(self.sizes) < 1 or max(self.sizes) > 40:
            raise ValueError(f"sizes must be in 1..40, got {self.sizes}")
        if self.trials < 1 or self.jobs < 1:
            raise ValueError("trials and jobs must be >= 1")
        if not 0 < self.max_time <= 3600:
            raise ValueError(f"max_time must be in (0, 3600] seconds, got {self.max_time}")
        if self.memory_mb < 512:
            raise ValueError(f"memory_mb must be >= 512, got {self.memory_mb}")


def label(mode: str, quality: str) -> str:
    """A table column: the mode, followed by ``+QUALITY`` unless the quality is ``fast``."""
    return mode if quality == "fast" else f"{mode}+{quality}"


@dataclass(frozen=True)
class Trial:
    family: str
    size: int
    mode: str
    trial: int
    status: str  # the planner's status, "killed" or "crashed"
    valid: bool  # the plan validated (False when there is none)
    cpu: float  # CPU seconds of planning (process and children)
    wall: float
    translate_time: float
    search_time: float
    stream_time: float
    stream_calls: int
    iterations: int
    plan_length: int
    validation: str  # "ok", or why the plan (or the run) failed
    check_cpu: float = 0.0  # CPU seconds of the validation (deferred streams evaluated there)
    jobs: int = 1  # trials running in parallel while this one was timed
    quality: str = "fast"
    cost: float | None = None  # the validator's cost of the plan (real values)
    improvements: str = ""  # JSON [[cpu s, planner's cost], ...]: each cheaper plan found

    @property
    def solved(self) -> bool:
        return self.status == "solved" and self.valid

    @property
    def column(self) -> str:
        return label(self.mode, self.quality)

    def timeline(self) -> list[tuple[float, float]]:
        """(CPU s, cost) of each cheaper plan found (the planner's costs)."""
        return [(float(c), float(v)) for c, v in json.loads(self.improvements or "[]")]


@dataclass(frozen=True)
class Payload:
    family: str
    size: int
    mode: str
    trial: int
    max_time: float
    memory_mb: int
    jobs: int
    share: bool = False
    quality: str = "fast"
    files: str | None = None


def planner_config(
    mode: str, trial: int, max_time: float, share: bool = False, quality: str = "fast"
) -> PlannerConfig:
    return PlannerConfig(
        defer=(mode == "deferred"),
        max_time=max_time,
        search_time=max_time,
        seed=trial,
        share_placeholders=share,
        quality=quality,  # type: ignore[arg-type]
    )


def _cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def measure(p: Payload) -> dict[str, Any]:
    """Plan one trial in this process and validate its plan: the fields of a :class:`Trial`."""
    if p.files is None:
        world, problem = make_problem(p.family, p.size, p.trial)
    else:
        instance, problem = pds_files.make_problem(Path(p.files), p.family, p.size, p.trial)
    cpu0, wall0 = _cpu(), time.perf_counter()
    result = solve(problem, planner_config(p.mode, p.trial, p.max_time, p.share, p.quality))
    cpu, wall = _cpu() - cpu0, time.perf_counter() - wall0
    plan = result.plan
    cpu1 = _cpu()
    check: Any = None
    if plan is not None:
        check = (
            validate(world, problem, plan)
            if p.files is None
            else pds_files.validate(instance, problem, plan)
        )
    check_cpu = _cpu() - cpu1
    s = result.stats
    return {
        **asdict(p),
        "status": result.status.value,
        "valid": bool(check and check.valid),
        "cpu": cpu,
        "wall": wall,
        "translate_time": s.translate_time,
        "search_time": s.search_time,
        "stream_time": s.stream_time,
        "stream_calls": sum(s.stream_calls.values()),
        "iterations": s.iterations,
        "plan_length": len(plan) if plan is not None else 0,
        "validation": check.message if check else result.message[:300],
        "check_cpu": check_cpu,
        "cost": check.cost if check else None,
        "improvements": json.dumps([[i.cpu, i.cost] for i in result.improvements]),
    }


def _child(p: Payload, conn: Connection) -> None:
    os.setsid()  # its own process group: a kill also ends the searches it started
    limit = p.memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    logging.disable(logging.WARNING)
    try:
        conn.send(measure(p))
    except MemoryError:
        conn.send(_failed(p, "crashed", f"out of memory ({p.memory_mb} MB)"))
    except Exception as e:  # reported as the trial's outcome, the run goes on
        conn.send(_failed(p, "crashed", f"{type(e).__name__}: {e}"[:300]))
    finally:
        conn.close()


def _failed(p: Payload, status: str, why: str) -> dict[str, Any]:
    zero = dict.fromkeys(("translate_time", "search_time", "stream_time"), 0.0)
    return {
        **asdict(p),
        **zero,
        "status": status,
        "valid": False,
        "cpu": p.max_time,
        "wall": p.max_time,
        "stream_calls": 0,
        "iterations": 0,
        "plan_length": 0,
        "validation": why,
    }


def run_job(p: Payload) -> dict[str, Any]:
    """Run one trial in a fresh process with a memory limit and a hard deadline."""
    ctx = multiprocessing.get_context("spawn")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(p, send), daemon=False)
    proc.start()
    send.close()
    deadline = time.monotonic() + p.max_time + KILL_GRACE
    out: dict[str, Any] | None = None
    while out is None and time.monotonic() < deadline:
        if recv.poll(0.2):
            try:
                out = recv.recv()
            except EOFError:
                break
        elif not proc.is_alive() and not recv.poll(0):
            break
    if proc.is_alive() and proc.pid is not None:
        with contextlib.suppress(ProcessLookupError):  # its group exists once it called setsid
            os.killpg(proc.pid, signal.SIGKILL)
        proc.kill()
    proc.join()
    recv.close()
    if out is not None:
        return out
    if time.monotonic() >= deadline:
        return _failed(p, "killed", f"killed {KILL_GRACE:g} s after the {p.max_time:g} s limit")
    return _failed(p, "crashed", f"the trial's process exited with {proc.exitcode}")


# ------------------------------------------------------------------------------------ running


@dataclass(frozen=True)
class Row:
    """One family at one size: per column (mode and quality) the median CPU and cost of the
    solved trials and how many solved."""

    family: str
    size: int
    trials: int
    cpu: dict[str, float | None]
    wall: dict[str, float | None]
    solved: dict[str, int]
    invalid: dict[str, int]  # plans returned that did not validate
    run: dict[str, bool]  # False: skipped (a smaller size solved nothing)
    cost: dict[str, float | None] = field(default_factory=dict)

    @property
    def speedup(self) -> float | None:
        c, d = self.cpu.get("computed"), self.cpu.get("deferred")
        return None if c is None or d is None or d <= 0 else c / d


@dataclass(frozen=True)
class Report:
    trials: tuple[Trial, ...]
    rows: tuple[Row, ...]
    files: tuple[Path, ...] = field(default_factory=tuple)


def code_fingerprint() -> str:
    """A hash of the code a trial's result depends on: the domain package (PDDL files and
    streams) and the planner; a changed file never reuses a cached result."""
    texts = []
    for package in (
        "llmpas.examples.tamp2d_pds",
        "llmpas.planning",
        "llmpas.language",
        "llmpas.experiments",
    ):
        root = files(package)
        texts += [
            (package, f.name, f.read_text(encoding="utf-8"))
            for f in sorted(root.iterdir(), key=lambda f: f.name)
            if f.name.endswith((".py", ".pddl"))
        ]
    return fingerprint(texts)


def jobs_for(
    config: TampBenchConfig, size: int, combos: Iterable[tuple[str, str, str]]
) -> list[Job]:
    out = []
    code = code_fingerprint()
    files = None if config.files is None else str(config.files.resolve())
    source: list[Any] = [] if files is None else [files, _files_text(config.files)]
    for family, mode, quality in combos:
        for trial in range(config.trials):
            settings = asdict(planner_config(mode, trial, config.max_time, config.share, quality))
            digest = fingerprint(
                [family, size, mode, trial, settings, config.memory_mb, code, *source]
            )
            key = f"{family}/n{size}/{label(mode, quality)}/trial{trial}/{digest}"
            payload = Payload(
                family,
                size,
                mode,
                trial,
                config.max_time,
                config.memory_mb,
                config.jobs,
                config.share,
                quality,
                files,
            )
            out.append(Job(key, payload))
    return out


def _files_text(folder: Path | None) -> list[str]:
    return [] if folder is None else [(folder / f).read_text() for f in pds_files.FILES]


def run_tamp(config: TampBenchConfig, console: Console | None = None) -> Report:
    """Run (or resume) every trial, size by size; write the CSV, table and plot."""
    console = console or Console()
    if config.jobs > 1:
        log.warning("bench tamp with %d parallel trials: CPU times are contended", config.jobs)
    combos = [(f, m, q) for f in config.families for m in config.modes for q in config.qualities]
    trials: list[Trial] = []
    for size in sorted(set(config.sizes)):
        if not combos:
            break
        jobs = jobs_for(config, size, combos)
        now = rows_of(Trial, run_trials(config, jobs, run_job, f"bench tamp N={size}", console))
        trials += now
        if not config.keep_going:
            combos = [
                c
                for c in combos
                if any(t.solved for t in now if (t.family, t.mode, t.quality) == c)
            ]
    rows = summarise(trials, config)
    files = write_outputs(trials, rows, config)
    console.print(markdown_table(rows, config, cpu_share(trials)))
    return Report(tuple(trials), rows, files)


def summarise(trials: Sequence[Trial], config: TampBenchConfig) -> tuple[Row, ...]:
    rows = []
    for family in config.families:
        for size in sorted(set(config.sizes)):
            cpu: dict[str, float | None] = {}
            wall: dict[str, float | None] = {}
            cost: dict[str, float | None] = {}
            solved: dict[str, int] = {}
            invalid: dict[str, int] = {}
            ran: dict[str, bool] = {}
            for col in config.columns:
                ts = [t for t in trials if (t.family, t.size, t.column) == (family, size, col)]
                ok = [t for t in ts if t.solved]
                costs = [t.cost for t in ok if t.cost is not None]
                cpu[col] = statistics.median(t.cpu for t in ok) if ok else None
                wall[col] = statistics.median(t.wall for t in ok) if ok else None
                cost[col] = statistics.median(costs) if costs else None
                solved[col] = len(ok)
                invalid[col] = sum(t.status == "solved" and not t.valid for t in ts)
                ran[col] = bool(ts)
            rows.append(Row(family, size, config.trials, cpu, wall, solved, invalid, ran, cost))
    return tuple(rows)


# ------------------------------------------------------------------------------------ outputs


def _fmt(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f}"


def _cell(r: Row, col: str) -> str:
    if not r.run[col]:
        return "not run | — | —"
    bad = f", {r.invalid[col]} invalid" if r.invalid[col] else ""
    cost = "—" if r.cost.get(col) is None else f"{r.cost[col]:.1f}"
    return f"{_fmt(r.cpu[col])} | {cost} | {r.solved[col]}/{r.trials}{bad}"


def _reference(family: str, size: int) -> str:
    ref = REFERENCE.get(family, {})
    if size not in ref:
        return "—"
    value = ref[size]
    return "unsolved" if value is None else f"{value:g}"


def cpu_share(trials: Sequence[Trial]) -> float | None:
    """Median CPU / wall of the solved trials that took at least 1 s of wall: near 1 on an
    idle machine, lower when other work competed for the cores."""
    shares = [t.cpu / t.wall for t in trials if t.solved and t.wall >= 1.0]
    return statistics.median(shares) if shares else None


def markdown_table(rows: Iterable[Row], config: TampBenchConfig, share: float | None = None) -> str:
    jobs = "trials one at a time" if config.jobs == 1 else f"{config.jobs} parallel: contended"
    where = (
        "pds-tamp2d"
        if config.files is None
        else "PDDLStream's continuous_tamp files with llmpas's 2-D streams"
    )
    cols = config.columns
    header = " | ".join(f"{c} CPU (s) | cost | solved" for c in cols)
    lines = [
        f"Planning CPU time and plan cost on {where} (median of solved and validated trials, CPU "
        f"seconds of the planner's process and its Fast Downward children, cost of the plan "
        f"replayed on the real values; {config.trials} seeded trials per size, limit "
        f"{config.max_time:g} s wall per trial; {jobs}). Last column: {REFERENCE_LABEL}.",
        "",
        f"| family | N | {header} | computed / deferred | PDDLStream ref. (s) |",
        "|---|---:|" + "---:|---:|---:|" * len(cols) + "---:|---:|",
    ]
    for r in rows:
        ratio = "—" if r.speedup is None else f"{r.speedup:.1f}x"
        cells = " | ".join(_cell(r, c) for c in cols)
        lines.append(
            f"| {r.family} | {r.size} | {cells} | {ratio} | {_reference(r.family, r.size)} |"
        )
    lines += [
        "",
        "not run: the same mode solved no trial at a smaller size. Unsolved includes timeouts "
        "and plans that failed validation (counted as invalid).",
    ]
    if share is not None:
        lines.append(
            f"Median CPU / wall of the solved trials over 1 s: {share:.2f} (1 on an idle "
            "machine; lower when other work shared the cores, which makes the wall-clock limit "
            "tighter in CPU seconds)."
        )
    return "\n".join(lines) + "\n"


def write_outputs(
    trials: Sequence[Trial], rows: Sequence[Row], config: TampBenchConfig
) -> tuple[Path, ...]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    csv_path = write_csv(out / "tamp.csv", [asdict(t) for t in trials])
    md_path = atomic_write(out / "tamp.md", markdown_table(rows, config, cpu_share(trials)))
    png_path = out / "tamp.png"
    plot(trials, rows, config, png_path)
    written = [csv_path, md_path, png_path]
    if "anytime" in config.qualities and any(t.quality == "anytime" and t.solved for t in trials):
        written.append(out / "tamp-anytime.png")
        plot_anytime(trials, config, written[-1])
    return tuple(written)


def plot(trials: Sequence[Trial], rows: Sequence[Row], config: TampBenchConfig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    families = list(config.families)
    fig, axes = plt.subplots(1, len(families), figsize=(6 * len(families), 4.5), squeeze=False)
    palette = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown")
    colors = dict(zip(config.columns, palette, strict=False))
    for ax, fam in zip(axes[0], families, strict=True):
        for mode in config.columns:
            pts = [t for t in trials if t.family == fam and t.column == mode]
            ok = [t for t in pts if t.solved]
            bad = [t for t in pts if not t.solved]
            ax.scatter(
                [t.size for t in ok], [t.cpu for t in ok], s=12, alpha=0.35, color=colors[mode]
            )
            ax.scatter(
                [t.size for t in bad],
                [config.max_time] * len(bad),
                marker="x",
                s=30,
                color=colors[mode],
            )
            med = [(r.size, r.cpu[mode]) for r in rows if r.family == fam and r.cpu[mode]]
            what = "every stream computed" if mode.startswith("computed") else "IK, motion deferred"
            quality = mode.partition("+")[2] or "fast"
            ax.plot(
                [s for s, _ in med],
                [m for _, m in med],
                "-o",
                color=colors[mode],
                label=f"llmpas, {what}, {quality} (median)",
            )
        _plot_reference(ax, fam, config.max_time)
        ax.axhline(config.max_time, color="gray", ls=":", lw=1)
        ax.set_yscale("log")
        ax.set_xticks(sorted(set(config.sizes) | set(REFERENCE.get(fam, {}))))
        ax.set_xlabel("N (blocks)")
        ax.set_ylabel("planning CPU time (s)")
        ax.set_title(f"{fam}: x = unsolved or invalid within {config.max_time:g} s")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="upper left", fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def plot_anytime(trials: Sequence[Trial], config: TampBenchConfig, path: Path) -> None:
    """Anytime: each trial's plan cost over CPU time at one N (``config.anytime_size``, else the
    largest N where an anytime trial solved), one panel per family; a step per cheaper plan."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    solved = [t for t in trials if t.quality == "anytime" and t.solved]
    size = config.anytime_size or max(t.size for t in solved)
    families = list(config.families)
    fig, axes = plt.subplots(1, len(families), figsize=(6 * len(families), 4.2), squeeze=False)
    for ax, fam in zip(axes[0], families, strict=True):
        for t in [t for t in solved if (t.family, t.size) == (fam, size)]:
            points = t.timeline()
            xs = [c for c, _ in points] + [t.cpu]
            ys = [v for _, v in points] + [points[-1][1]]
            ax.step(xs, ys, where="post", marker="o", ms=3, label=f"{t.mode}, seed {t.trial}")
        ax.set_xlabel("planning CPU time (s)")
        ax.set_ylabel("plan cost (planner's)")
        ax.set_title(f"{fam}, N = {size}: anytime, each cheaper plan (last point: it stops)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _plot_reference(ax: Any, family: str, max_time: float) -> None:
    """PDDLStream's figures: a dashed gray line, gray crosses where it solved nothing."""
    ref = sorted(REFERENCE.get(family, {}).items())
    solved = [(n, v) for n, v in ref if v is not None]
    label = REFERENCE_LABEL.replace(", not", ",\nnot")
    if solved:
        ax.plot(
            [n for n, _ in solved], [v for _, v in solved], "--s", color="gray", ms=4, label=label
        )
    unsolved = [n for n, v in ref if v is None]
    if unsolved:
        ax.scatter(
            unsolved,
            [max_time] * len(unsolved),
            marker="x",
            s=30,
            color="gray",
            label="PDDLStream: unsolved (its 10 s limit)",
        )


# ---------------------------------------------------------------------------------------- CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench tamp``."""
    p.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    p.add_argument("--sizes", nargs="+", type=int, default=list(range(1, 9)), help="blocks")
    p.add_argument("--trials", type=int, default=3, help="seeded trials per size and mode")
    p.add_argument("--max-time", type=float, default=60.0, help="seconds per planning run")
    p.add_argument("--memory-mb", type=int, default=3072, help="address space of a trial")
    p.add_argument("--keep-going", action="store_true", help="run sizes past an unsolved one")
    p.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    p.add_argument(
        "--qualities",
        nargs="+",
        default=["fast"],
        choices=tuple(QUALITIES),
        help="plan qualities to run in each mode (a column each)",
    )
    p.add_argument("--anytime-size", type=int, help="N of the anytime plot (default: largest)")
    p.add_argument(
        "--pddlstream-files",
        metavar="DIR",
        help="plan PDDLStream's examples/continuous_tamp domain.pddl and stream.pddl from DIR "
        "(with llmpas's own 2-D streams) instead of pds-tamp2d",
    )
    p.add_argument(
        "--share-placeholders",
        action="store_true",
        help="one placeholder per stream output and level, as PDDLStream (an unsolvable task "
        "is planned again with one per instance)",
    )


def config_from(args: argparse.Namespace, shared: Shared) -> TampBenchConfig:
    return TampBenchConfig(
        families=tuple(args.families),
        sizes=tuple(args.sizes),
        trials=args.trials,
        max_time=args.max_time,
        jobs=shared.jobs,
        memory_mb=args.memory_mb,
        keep_going=args.keep_going,
        out_dir=shared.out_dir,
        executor=shared.executor,
        share=args.share_placeholders,
        modes=tuple(args.modes),
        qualities=tuple(args.qualities),
        files=Path(args.pddlstream_files) if args.pddlstream_files else None,
        anytime_size=args.anytime_size,
    )


def _run(config: TampBenchConfig, console: Console) -> tuple[Path, ...]:
    return run_tamp(config, console).files


def _in_all(config: AllConfig) -> tuple[str, ...]:
    quick = ("--sizes", "1", "--trials", "1") if config.quick else ()
    return (*quick, *config.outputs("tamp"))


BENCHMARK = Harnessed(
    "tamp",
    "2-D continuous TAMP (mirror, packed): computed vs deferred",
    add_arguments,
    config_from,
    _run,
    SharedOptions(
        out="results/tamp",
        out_help="folder for table, plot and cache",
        jobs_help="parallel trials (> 1: contended)",
    ),
    _in_all,
)

__all__ = [
    "BENCHMARK",
    "MODES",
    "REFERENCE",
    "REFERENCE_LABEL",
    "Payload",
    "Report",
    "Row",
    "TampBenchConfig",
    "Trial",
    "add_arguments",
    "config_from",
    "label",
    "plot_anytime",
    "run_tamp",
]
