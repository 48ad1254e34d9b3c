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
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import multiprocessing
import os
import resource
import signal
import statistics
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field, fields
from importlib.resources import files
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.examples.tamp2d_pds import FAMILIES, make_problem
from llmpas.examples.tamp2d_pds.validate import validate
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    add_executor_arguments,
    executor_from_args,
    fingerprint,
    run_jobs,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.planning import PlannerConfig, solve

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

    def __post_init__(self) -> None:
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

    @property
    def solved(self) -> bool:
        return self.status == "solved" and self.valid


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


def planner_config(mode: str, trial: int, max_time: float, share: bool = False) -> PlannerConfig:
    return PlannerConfig(
        defer=(mode == "deferred"),
        max_time=max_time,
        search_time=max_time,
        seed=trial,
        share_placeholders=share,
    )


def _cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def measure(p: Payload) -> dict[str, Any]:
    """Plan one trial in this process and validate its plan: the fields of a :class:`Trial`."""
    world, problem = make_problem(p.family, p.size, p.trial)
    cpu0, wall0 = _cpu(), time.perf_counter()
    result = solve(problem, planner_config(p.mode, p.trial, p.max_time, p.share))
    cpu, wall = _cpu() - cpu0, time.perf_counter() - wall0
    plan = result.plan
    cpu1 = _cpu()
    check = validate(world, problem, plan) if plan is not None else None
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
    """One family at one size: per mode the median CPU of solved trials and how many solved."""

    family: str
    size: int
    trials: int
    cpu: dict[str, float | None]
    wall: dict[str, float | None]
    solved: dict[str, int]
    invalid: dict[str, int]  # plans returned that did not validate
    run: dict[str, bool]  # False: skipped (a smaller size solved nothing)

    @property
    def speedup(self) -> float | None:
        c, d = self.cpu["computed"], self.cpu["deferred"]
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
    for package in ("llmpas.examples.tamp2d_pds", "llmpas.planning", "llmpas.language"):
        root = files(package)
        texts += [
            (package, f.name, f.read_text(encoding="utf-8"))
            for f in sorted(root.iterdir(), key=lambda f: f.name)
            if f.name.endswith((".py", ".pddl"))
        ]
    return fingerprint(texts)


def jobs_for(config: TampBenchConfig, size: int, combos: Iterable[tuple[str, str]]) -> list[Job]:
    out = []
    code = code_fingerprint()
    for family, mode in combos:
        for trial in range(config.trials):
            settings = asdict(planner_config(mode, trial, config.max_time, config.share))
            digest = fingerprint([family, size, mode, trial, settings, config.memory_mb, code])
            key = f"{family}/n{size}/{mode}/trial{trial}/{digest}"
            payload = Payload(
                family,
                size,
                mode,
                trial,
                config.max_time,
                config.memory_mb,
                config.jobs,
                config.share,
            )
            out.append(Job(key, payload))
    return out


def _trial(result: dict[str, Any]) -> Trial:
    names = {f.name for f in fields(Trial)}
    return Trial(**{k: v for k, v in result.items() if k in names})


def run_tamp(config: TampBenchConfig, console: Console | None = None) -> Report:
    """Run (or resume) every trial, size by size; write the CSV, table and plot."""
    console = console or Console()
    if config.jobs > 1:
        log.warning("bench tamp with %d parallel trials: CPU times are contended", config.jobs)
    combos = [(f, m) for f in config.families for m in MODES]
    trials: list[Trial] = []
    for size in sorted(set(config.sizes)):
        if not combos:
            break
        results = run_jobs(
            jobs_for(config, size, combos),
            run_job,
            config.out_dir / "cache",
            workers=config.jobs,
            executor=config.executor,
            description=f"bench tamp N={size}",
            console=console,
        )
        now = [_trial(r) for r in results]
        trials += now
        if not config.keep_going:
            combos = [c for c in combos if any(t.solved for t in now if (t.family, t.mode) == c)]
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
            solved: dict[str, int] = {}
            invalid: dict[str, int] = {}
            ran: dict[str, bool] = {}
            for mode in MODES:
                ts = [t for t in trials if (t.family, t.size, t.mode) == (family, size, mode)]
                ok = [t for t in ts if t.solved]
                cpu[mode] = statistics.median(t.cpu for t in ok) if ok else None
                wall[mode] = statistics.median(t.wall for t in ok) if ok else None
                solved[mode] = len(ok)
                invalid[mode] = sum(t.status == "solved" and not t.valid for t in ts)
                ran[mode] = bool(ts)
            rows.append(Row(family, size, config.trials, cpu, wall, solved, invalid, ran))
    return tuple(rows)


# ------------------------------------------------------------------------------------ outputs


def _fmt(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f}"


def _cell(r: Row, mode: str) -> str:
    if not r.run[mode]:
        return "not run | —"
    bad = f", {r.invalid[mode]} invalid" if r.invalid[mode] else ""
    return f"{_fmt(r.cpu[mode])} | {r.solved[mode]}/{r.trials}{bad}"


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
    lines = [
        f"Planning CPU time on pds-tamp2d (median of solved and validated trials, CPU seconds of "
        f"the planner's process and its Fast Downward children; {config.trials} seeded trials "
        f"per size, limit {config.max_time:g} s wall per trial; {jobs}). Last column: "
        f"{REFERENCE_LABEL}.",
        "",
        "| family | N | computed CPU (s) | solved | deferred CPU (s) | solved "
        "| computed / deferred "
        "| computed wall (s) | PDDLStream ref. (s) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        ratio = "—" if r.speedup is None else f"{r.speedup:.1f}x"
        lines.append(
            f"| {r.family} | {r.size} | {_cell(r, 'computed')} | {_cell(r, 'deferred')} | "
            f"{ratio} | {_fmt(r.wall['computed'])} | {_reference(r.family, r.size)} |"
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
    return (csv_path, md_path, png_path)


def plot(trials: Sequence[Trial], rows: Sequence[Row], config: TampBenchConfig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    families = list(config.families)
    fig, axes = plt.subplots(1, len(families), figsize=(6 * len(families), 4.5), squeeze=False)
    colors = {"computed": "tab:red", "deferred": "tab:blue"}
    for ax, fam in zip(axes[0], families, strict=True):
        for mode in MODES:
            pts = [t for t in trials if t.family == fam and t.mode == mode]
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
            label = "every stream computed" if mode == "computed" else "IK and motion deferred"
            ax.plot(
                [s for s, _ in med],
                [m for _, m in med],
                "-o",
                color=colors[mode],
                label=f"llmpas, {label} (median)",
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
    p.add_argument("--jobs", type=int, default=1, help="parallel trials (> 1: contended)")
    p.add_argument("--out", default="results/tamp", help="folder for table, plot and cache")
    p.add_argument(
        "--share-placeholders",
        action="store_true",
        help="one placeholder per stream output and level, as PDDLStream (an unsolvable task "
        "is planned again with one per instance)",
    )
    add_executor_arguments(p)


def command(args: argparse.Namespace, console: Console) -> int:
    config = TampBenchConfig(
        families=tuple(args.families),
        sizes=tuple(args.sizes),
        trials=args.trials,
        max_time=args.max_time,
        jobs=args.jobs,
        memory_mb=args.memory_mb,
        keep_going=args.keep_going,
        out_dir=Path(args.out),
        executor=executor_from_args(args),
        share=args.share_placeholders,
    )
    report = run_tamp(config, console)
    console.print(f"wrote {', '.join(str(p) for p in report.files)}")
    return 0


__all__ = [
    "MODES",
    "REFERENCE",
    "REFERENCE_LABEL",
    "Payload",
    "Report",
    "Row",
    "TampBenchConfig",
    "Trial",
    "add_arguments",
    "command",
    "run_tamp",
]
