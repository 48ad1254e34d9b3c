"""``llmpas bench pddlstream DIR``: PDDLStream example scripts the user supplies, run unchanged
through ``llmpas pddlstream`` over several seeds; optionally beside a real PDDLStream.

PDDLStream is GPL-3: nothing of it ships with llmpas. ``DIR`` is a folder of scripts written
for PDDLStream's API (e.g. a copy of its ``examples/`` folder); an *instance* is one script
with its arguments (``--instance "pybullet/tamp/run.py -teleport -n 4"``, a path relative to
``DIR``; default: every ``run.py`` under ``DIR``, else every script there that imports
``pddlstream`` and runs as ``__main__``).

Each trial is one process: ``llmpas pddlstream --seed S --summary F SCRIPT ARGS`` (Python's and
numpy's global generators seeded with ``S`` before the script runs; a script that seeds them
itself overrides it). Per trial: solved (some ``solve`` call returned a plan), validated (every
plan returned replays: :mod:`llmpas.pddlstream.solution_check`), length and cost of the last
plan, and
the CPU seconds of the whole process and of the processes it waited for (Fast Downward's
searches), from ``wait4``; a process that outlives ``--timeout`` is killed (its CPU up to then
counts, and it is unsolved).

*Side by side* (``--pddlstream ROOT``, a PDDLStream checkout: the folder holding its
``pddlstream`` package, built as its README says): the same scripts, seeds and limits run under
that PDDLStream with ``--pddlstream-python`` (its own environment's interpreter; a real
PDDLStream in the same environment as llmpas meets PyPI's ``pddl`` package first, see
docs/pddlstream.md). Its solved, length and cost are read from what the script prints
(PDDLStream's ``print_solution``: ``Solved:``, ``Cost:``, ``Length:``); its plans are not
validated here. The table's ratio is llmpas's median CPU over PDDLStream's, per instance,
measured in the same run.

Trials are cached jobs (:mod:`llmpas.experiments.jobs`): an interrupted run resumes; a changed
script or a changed planner never reuses a result.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import shlex
import signal
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from importlib.resources import files
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.experiments import pds_profile
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions, rows_of, run_trials
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    fingerprint,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.pddlstream.runner import package_root

PLANNERS = ("llmpas", "pddlstream")
KILL_GRACE = 5.0  # seconds between SIGTERM and SIGKILL of a trial past its timeout
_MAIN = re.compile(r"__name__\s*==\s*['\"]__main__['\"]")
_IMPORTS = re.compile(r"^\s*(from|import)\s+pddlstream\b", re.MULTILINE)

#: Runs a script as ``python -m`` would from the top of its package, after seeding the global
#: generators: the same start for a real PDDLStream as ``llmpas pddlstream --seed`` gives.
_BOOT = """
import runpy, sys
from pathlib import Path
seed, script, argv = int(sys.argv[1]), Path(sys.argv[2]).resolve(), sys.argv[3:]
import random
random.seed(seed)
try:
    import numpy
    numpy.random.seed(seed % 2**32)
except ImportError:
    pass
folder, parts = script.parent, [script.stem]
while (folder / "__init__.py").is_file():
    parts.insert(0, folder.name)
    folder = folder.parent
sys.path.insert(0, str(folder if len(parts) > 1 else script.parent))
sys.argv = [str(script), *argv]
if len(parts) > 1:
    runpy.run_module(".".join(parts), run_name="__main__", alter_sys=True)
else:
    runpy.run_path(str(script), run_name="__main__")
"""


@dataclass(frozen=True)
class Instance:
    """One script of ``DIR`` (relative path) with its arguments."""

    script: str
    args: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        return " ".join((self.script, *self.args))

    @classmethod
    def parse(cls, text: str) -> Instance:
        words = shlex.split(text)
        if not words:
            raise ValueError("--instance: an empty instance (give a script and its arguments)")
        return cls(words[0], tuple(words[1:]))


@dataclass(frozen=True)
class PdsBenchConfig:
    folder: Path
    instances: tuple[Instance, ...] = ()  # () : found in the folder (module docstring)
    seeds: int = 3
    timeout: float = 300.0  # seconds of wall per trial, past the script's own limits
    pddlstream: Path | None = None  # a PDDLStream checkout: run it side by side
    python: str | None = None  # its interpreter (default: this one)
    out_dir: Path = Path("results/pddlstream")
    profile: bool = False  # each trial under cProfile, split by category (pds_profile)
    jobs: int = 1
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)

    def __post_init__(self) -> None:
        if not self.folder.is_dir():
            raise ValueError(f"bench pddlstream: {self.folder}: no such folder")
        for inst in self.instances:
            if not (self.folder / inst.script).is_file():
                raise ValueError(f"bench pddlstream: {self.folder / inst.script}: no such script")
        if self.seeds < 1 or self.jobs < 1:
            raise ValueError("seeds and jobs must be >= 1")
        if not 0 < self.timeout <= 7200:
            raise ValueError(f"timeout must be in (0, 7200] seconds, got {self.timeout}")
        if self.pddlstream is not None and not (self.pddlstream / "pddlstream").is_dir():
            raise ValueError(
                f"--pddlstream {self.pddlstream}: no pddlstream package there (give the folder "
                "of a PDDLStream checkout that holds pddlstream/)"
            )
        if self.python is not None and self.pddlstream is None:
            raise ValueError("--pddlstream-python needs --pddlstream (the checkout to run)")

    @property
    def planners(self) -> tuple[str, ...]:
        return PLANNERS if self.pddlstream is not None else PLANNERS[:1]


def find_instances(folder: Path) -> tuple[Instance, ...]:
    """Every ``run.py`` under ``folder``; without any, every script there that imports
    ``pddlstream`` and runs as ``__main__``."""
    runs = sorted(p for p in folder.rglob("run.py") if p.is_file())
    if not runs:
        runs = sorted(
            p
            for p in folder.rglob("*.py")
            if p.is_file()
            and _IMPORTS.search(t := p.read_text(errors="replace"))
            and _MAIN.search(t)
        )
    return tuple(Instance(p.relative_to(folder).as_posix()) for p in runs)


@dataclass(frozen=True)
class Payload:
    planner: str
    folder: str
    instance: Instance
    seed: int
    timeout: float
    pddlstream: str | None = None
    python: str | None = None
    profile: bool = False


@dataclass(frozen=True)
class Trial:
    planner: str
    instance: str
    seed: int
    status: str  # ok | timeout | failed
    solved: bool
    validated: bool | None  # None: not checked (PDDLStream's own runs)
    length: int | None
    cost: float | None
    cpu: float  # the process and the processes it waited for
    wall: float
    solve_cpu: float | None = None  # llmpas: its solve calls' own CPU
    exit_code: int | None = None
    note: str = ""


def _command(p: Payload, summary: Path) -> tuple[list[str], dict[str, str], str]:
    script = str(Path(p.folder) / p.instance.script)
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}  # scripts' GUIs off
    env["MPLBACKEND"] = "Agg"
    if p.profile:
        env[pds_profile.ENV] = str(summary.parent)
    if p.planner == "llmpas":
        boot = "import sys; from llmpas.cli import main; sys.exit(main())"
        if p.profile:
            boot = pds_profile.LLMPAS_PRELUDE + "\nimport sys\nfrom llmpas.cli import main\n"
            boot += "sys.exit(_profiled(main))\n"
        argv = [sys.executable, "-c", boot, "pddlstream", "--seed", str(p.seed)]
        argv += ["--summary", str(summary), script, *p.instance.args]
        # from the top of the script's package, as python -m: the folder a script is in may
        # hold packages named as installed ones (examples/pybullet/ and pybullet)
        return argv, env, str(package_root(Path(script).resolve())[0])
    assert p.pddlstream is not None
    env["PYTHONPATH"] = os.pathsep.join(x for x in (p.pddlstream, env.get("PYTHONPATH", "")) if x)
    python = p.python or sys.executable
    boot = _BOOT
    if p.profile:  # the script's run inside the profiler, after the prelude's imports
        body = "\n".join(
            "    " + ln for ln in _BOOT.split("if len(parts) > 1:")[1].splitlines()[1:]
        )
        boot = _BOOT.split("if len(parts) > 1:")[0] + pds_profile.PDDLSTREAM_PRELUDE
        boot += "\ndef _script():\n    if len(parts) > 1:\n" + body + "\n_profiled(_script)\n"
    argv = [python, "-c", boot, str(p.seed), script, *p.instance.args]
    return argv, env, p.pddlstream


def run_trial(p: Payload) -> dict[str, Any]:
    """Run one trial in its own process group; CPU from ``wait4`` (module docstring)."""
    import subprocess

    with tempfile.TemporaryDirectory(prefix="llmpas-pds-") as tmp:
        summary, out = Path(tmp) / "summary.json", Path(tmp) / "out.txt"
        argv, env, cwd = _command(p, summary)
        start = time.monotonic()
        with open(out, "wb") as sink:
            proc = subprocess.Popen(
                argv,
                cwd=cwd,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=sink,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
            status, usage, killed = _wait(proc.pid, start + p.timeout)
            proc.returncode = status  # reaped by wait4 above
        wall = time.monotonic() - start
        text = out.read_text(errors="replace")
        cpu = usage.ru_utime + usage.ru_stime
        code = os.waitstatus_to_exitcode(status)
        base = {
            "planner": p.planner,
            "instance": p.instance.label,
            "seed": p.seed,
            "cpu": round(cpu, 3),
            "wall": round(wall, 3),
            "exit_code": code,
        }
        found = _from_summary(summary) if p.planner == "llmpas" else _from_output(text)
        if p.profile:
            prof = pds_profile.read_profile(summary.parent, p.planner)
            found["profile"] = None if prof is None else prof.as_dict()
        last = [ln for ln in text.splitlines() if ln.strip()][-1:] or [""]
        state = "timeout" if killed else ("ok" if code == 0 or found["solved"] else "failed")
        note = f"killed after {p.timeout:g} s" if killed else ("" if code == 0 else last[0][:300])
        return {**base, **found, "status": state, "note": note}


def _wait(pid: int, deadline: float) -> tuple[int, Any, bool]:
    """(wait status, rusage, killed) of ``pid``: SIGTERM to its group at ``deadline``, SIGKILL
    ``KILL_GRACE`` seconds later."""
    killed, term_at = False, None
    while True:
        done, status, usage = os.wait4(pid, os.WNOHANG)
        if done == pid:
            return status, usage, killed
        now = time.monotonic()
        if now >= deadline and term_at is None:
            killed, term_at = True, now
            _signal_group(pid, signal.SIGTERM)
        elif term_at is not None and now >= term_at + KILL_GRACE:
            _signal_group(pid, signal.SIGKILL)
        time.sleep(0.1)


def _signal_group(pid: int, sig: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(pid, sig)


def _from_summary(path: Path) -> dict[str, Any]:
    """What ``llmpas pddlstream --summary`` recorded (nothing solved without the file)."""
    none: dict[str, Any] = {"solved": False, "validated": False, "length": None, "cost": None}
    if not path.is_file():
        return {**none, "solve_cpu": None}
    solves = json.loads(path.read_text()).get("solves", [])
    solved = [s for s in solves if s.get("status") == "solved"]
    cpu = round(sum(float(s.get("cpu_seconds") or 0.0) for s in solves), 3)
    if not solved:
        return {**none, "solve_cpu": cpu}
    last = solved[-1]
    return {
        "solved": True,
        "validated": all(bool(s.get("valid")) for s in solved),
        "length": last.get("length"),
        "cost": last.get("cost"),
        "solve_cpu": cpu,
    }


_SOLVED = re.compile(r"^Solved:\s*(True|False)\s*$", re.MULTILINE)
_COST = re.compile(r"^Cost:\s*(\S+)\s*$", re.MULTILINE)
_LENGTH = re.compile(r"^Length:\s*(\S+)\s*$", re.MULTILINE)


def _from_output(text: str) -> dict[str, Any]:
    """Solved, cost and length from the last ``print_solution`` in a script's output."""
    solved = _SOLVED.findall(text)
    ok = bool(solved) and solved[-1] == "True"
    costs, lengths = _COST.findall(text), _LENGTH.findall(text)
    cost = _number(costs[-1]) if ok and costs else None
    length = _number(lengths[-1]) if ok and lengths else None
    return {
        "solved": ok,
        "validated": None,
        "length": None if length is None else int(length),
        "cost": cost,
        "solve_cpu": None,
    }


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


# ------------------------------------------------------------------------------------ running


def code_fingerprint() -> str:
    """The planner's code a trial depends on (a change never reuses a cached llmpas trial)."""
    texts = []
    for package in ("llmpas.planning", "llmpas.language", "llmpas.pddlstream"):
        root = files(package)
        texts += [
            (package, f.name, f.read_text(encoding="utf-8"))
            for f in sorted(root.iterdir(), key=lambda f: f.name)
            if f.name.endswith(".py")
        ]
    return fingerprint(texts)


def jobs_for(config: PdsBenchConfig, instances: Sequence[Instance]) -> list[Job[Payload]]:
    code = code_fingerprint()
    folder = config.folder.resolve()
    root = None if config.pddlstream is None else str(config.pddlstream.resolve())
    out = []
    for inst in instances:
        text = (folder / inst.script).read_text(errors="replace")
        for seed in range(config.seeds):  # both planners per seed: interleaved in time
            for planner in config.planners:
                payload = Payload(
                    planner,
                    str(folder),
                    inst,
                    seed,
                    config.timeout,
                    root if planner == "pddlstream" else None,
                    config.python if planner == "pddlstream" else None,
                    config.profile,
                )
                mine = code if planner == "llmpas" else root
                digest = fingerprint([asdict(payload), text, mine])
                out.append(Job(f"{planner}/{inst.label}/seed{seed}/{digest}", payload))
    return out


@dataclass(frozen=True)
class Row:
    """One instance under one planner, over its seeds."""

    instance: str
    planner: str
    trials: int
    solved: int
    validated: int | None
    length: float | None  # medians over the solved trials
    cost: float | None
    cpu: float  # median over every trial (a timeout counts with its CPU up to the kill)
    cpu_min: float
    cpu_max: float


def summarise(trials: Sequence[Trial]) -> tuple[Row, ...]:
    keys = list(dict.fromkeys((t.instance, t.planner) for t in trials))
    rows = []
    for inst, planner in keys:
        mine = [t for t in trials if (t.instance, t.planner) == (inst, planner)]
        ok = [t for t in mine if t.solved]
        cpus = [t.cpu for t in mine]
        checked = [t.validated for t in ok]
        rows.append(
            Row(
                inst,
                planner,
                len(mine),
                len(ok),
                None if any(v is None for v in checked) else sum(bool(v) for v in checked),
                _median([t.length for t in ok]),
                _median([t.cost for t in ok]),
                statistics.median(cpus),
                min(cpus),
                max(cpus),
            )
        )
    return tuple(rows)


def _median(values: Sequence[float | None]) -> float | None:
    xs = [float(v) for v in values if v is not None]
    return statistics.median(xs) if xs else None


def _fmt(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def markdown_table(rows: Sequence[Row], config: PdsBenchConfig) -> str:
    lines = [
        f"PDDLStream scripts of {config.folder}, {config.seeds} seed(s) each, "
        f"{config.timeout:g} s wall per trial.",
        "",
        "| script and arguments | planner | solved | validated | length | cost | CPU s "
        "(median, min-max) | CPU llmpas / PDDLStream |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    by = {(r.instance, r.planner): r for r in rows}
    for r in rows:
        ref = by.get((r.instance, "pddlstream"))
        ratio = "-"
        if r.planner == "llmpas" and ref is not None and ref.cpu > 0:
            ratio = f"{r.cpu / ref.cpu:.2f}"
        valid = "-" if r.validated is None else f"{r.validated}/{r.solved}"
        lines.append(
            f"| `{r.instance}` | {r.planner} | {r.solved}/{r.trials} | {valid} | "
            f"{_fmt(r.length, 1)} | {_fmt(r.cost)} | {r.cpu:.2f} ({r.cpu_min:.2f}-"
            f"{r.cpu_max:.2f}) | {ratio} |"
        )
    lines += [
        "",
        "CPU: the script's whole process and the processes it waited for (Fast Downward), every "
        "trial counted (an unsolved one with its CPU up to its end or kill). PDDLStream's plans "
        "are read from what the script prints and not validated here (-).",
    ]
    return "\n".join(lines) + "\n"


def plot(trials: Sequence[Trial], rows: Sequence[Row], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    instances = list(dict.fromkeys(r.instance for r in rows))
    planners = list(dict.fromkeys(r.planner for r in rows))
    colors = {"llmpas": "tab:blue", "pddlstream": "tab:gray"}
    fig, ax = plt.subplots(figsize=(max(6.0, 1.4 * len(instances) + 2), 4.8))
    width = 0.8 / max(1, len(planners))
    for k, planner in enumerate(planners):
        shift = (k - (len(planners) - 1) / 2) * width
        for i, inst in enumerate(instances):
            mine = [t for t in trials if (t.instance, t.planner) == (inst, planner)]
            ok = [t.cpu for t in mine if t.solved]
            bad = [t.cpu for t in mine if not t.solved]
            ax.scatter([i + shift] * len(ok), ok, s=14, alpha=0.5, color=colors[planner])
            ax.scatter([i + shift] * len(bad), bad, s=30, marker="x", color=colors[planner])
        med = [(i, r.cpu) for i, inst in enumerate(instances) for r in rows
               if (r.instance, r.planner) == (inst, planner)]  # fmt: skip
        ax.scatter(
            [i + shift for i, _ in med],
            [m for _, m in med],
            s=90,
            marker="_",
            color=colors[planner],
            label=f"{planner} (median; x: unsolved)",
        )
    ax.set_xticks(range(len(instances)))
    ax.set_xticklabels([_short(i) for i in instances], rotation=30, ha="right", fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("CPU s (process and its searches)")
    ax.set_title("PDDLStream scripts, one point per seed")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _short(label: str, width: int = 40) -> str:
    return label if len(label) <= width else "..." + label[-(width - 3) :]


@dataclass(frozen=True)
class Report:
    trials: tuple[Trial, ...]
    rows: tuple[Row, ...]
    files: tuple[Path, ...]


def run_bench(config: PdsBenchConfig, console: Console | None = None) -> Report:
    console = console or Console()
    instances = config.instances or find_instances(config.folder)
    if not instances:
        raise ValueError(
            f"bench pddlstream: no run.py, nor any script importing pddlstream, in {config.folder}"
        )
    results = run_trials(
        config, jobs_for(config, instances), run_trial, "bench pddlstream", console
    )
    trials = tuple(rows_of(Trial, results))
    rows = summarise(trials)
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    written: tuple[Path, ...] = (
        write_csv(out / "pddlstream.csv", [asdict(t) for t in trials]),
        atomic_write(out / "pddlstream.md", markdown_table(rows, config)),
        out / "pddlstream.png",
    )
    plot(trials, rows, written[-1])
    console.print(markdown_table(rows, config))
    if config.profile:
        written += _profile_report(results, out, console)
    return Report(trials, rows, written)


def _profile_report(
    results: Sequence[dict[str, Any]], out: Path, console: Console
) -> tuple[Path, ...]:
    """``profile.md`` (a table per instance), ``profile.csv`` (one row per trial) and
    ``profile-<instance>.png`` (stacked bars per planner)."""
    by: dict[str, dict[str, list[pds_profile.Profile]]] = {}
    flat = []
    for r in results:
        d = r.get("profile")
        if not d:
            continue
        prof = pds_profile.Profile.from_dict(d)
        by.setdefault(r["instance"], {}).setdefault(r["planner"], []).append(prof)
        row = {k: v for k, v in prof.as_dict().items() if k != "per_stream"}
        flat.append({"planner": r["planner"], "instance": r["instance"], "seed": r["seed"],
                     "solved": r["solved"], **row})  # fmt: skip
    text = "\n".join(pds_profile.profile_table(i, p) for i, p in by.items())
    files = [
        atomic_write(out / "profile.md", _PROFILE_HEAD + text),
        write_csv(out / "profile.csv", flat),
    ]
    for inst, planners in by.items():
        png = out / f"profile-{pds_profile.slug(inst)}.png"
        pds_profile.profile_plot(inst, planners, png)
        files.append(png)
    console.print(text)
    return tuple(files)


_PROFILE_HEAD = (
    "Profiled trials (`--profile`): each planner's process under cProfile with a CPU clock, "
    "its stream calls counted per stream from outside, Fast Downward's processes measured "
    "apart (llmpas/experiments/pds_profile.py says what each category holds). cProfile slows "
    "Python code more than C code: the split, not the sum, is the figure.\n\n"
)


# ---------------------------------------------------------------------------------------- CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("folder", metavar="DIR", help="a folder of PDDLStream scripts (its examples/)")
    p.add_argument(
        "--instance",
        action="append",
        default=[],
        metavar="'SCRIPT ARGS'",
        help="a script under DIR and its arguments (repeatable; default: every run.py)",
    )
    p.add_argument("--seeds", type=int, default=3, help="seeded runs per instance and planner")
    p.add_argument("--timeout", type=float, default=300.0, help="wall seconds per run")
    p.add_argument(
        "--pddlstream",
        metavar="ROOT",
        help="a PDDLStream checkout (the folder holding pddlstream/): run it side by side",
    )
    p.add_argument(
        "--pddlstream-python",
        metavar="PYTHON",
        help="the interpreter of PDDLStream's own environment (default: this one)",
    )
    p.add_argument(
        "--profile",
        action="store_true",
        help="profile each run: CPU per category and stream, searches, plans (profile.md)",
    )


def config_from(args: argparse.Namespace, shared: Shared) -> PdsBenchConfig:
    return PdsBenchConfig(
        folder=Path(args.folder),
        instances=tuple(Instance.parse(t) for t in args.instance),
        seeds=args.seeds,
        timeout=args.timeout,
        pddlstream=Path(args.pddlstream) if args.pddlstream else None,
        python=args.pddlstream_python,
        out_dir=shared.out_dir,
        profile=args.profile,
        jobs=shared.jobs,
        executor=shared.executor,
    )


def _run(config: PdsBenchConfig, console: Console) -> tuple[Path, ...]:
    return run_bench(config, console).files


BENCHMARK = Harnessed(
    "pddlstream",
    "PDDLStream example scripts (a folder you supply), optionally beside a real PDDLStream",
    add_arguments,
    config_from,
    _run,
    SharedOptions(
        out="results/pddlstream",
        out_help="folder for table, plot, cache",
        jobs_help="parallel runs (> 1: contended CPU)",
    ),
)

__all__ = [
    "BENCHMARK",
    "Instance",
    "Payload",
    "PdsBenchConfig",
    "Report",
    "Row",
    "Trial",
    "find_instances",
    "markdown_table",
    "run_bench",
    "run_trial",
    "summarise",
]
