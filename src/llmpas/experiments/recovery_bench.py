"""``llmpas bench recovery``: how the loop decides a recovery, per consultation.

It runs ``bench prompting`` (the suite, by default the no-model controls and the oracle, every
run kept) and reads each run's ``loop.json``: per consultation, the candidate goal sets checked,
how each was decided (``repeat``, ``invariant``: the domain's invariants, no planner call;
``already true``; ``no action makes it``; ``search``: the planner; ``limit``: a planner limit,
no verdict), the planner calls and the time; per run, how every plan ended (a ``timeout`` is a
time limit that fired: the one outcome that depends on the machine). The slowest consultations
and runs are listed with their goals. Writes ``recovery.md``, ``recovery.csv`` (one row per
check) and ``recovery.png``.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.experiments.harness import Harnessed, Shared
from llmpas.experiments.prompting import SHARED, PromptingConfig, config_from_args, run_prompting
from llmpas.experiments.prompting import add_arguments as prompting_arguments
from llmpas.files import atomic_write
from llmpas.system.records import DECIDED_BY

CONTROLS = ("candidates-first", "candidates-shuffled", "candidates-random")
SLOWEST = 10  # consultations and runs listed


@dataclass(frozen=True)
class Consulted:
    """One consultation of one run: its checks (``loop.json``'s records) in order."""

    row: str
    task: str
    round: int
    checks: tuple[dict[str, Any], ...]

    @property
    def seconds(self) -> float:
        return sum(float(c["seconds"]) for c in self.checks)

    @property
    def planner_calls(self) -> int:
        return sum(int(c["planner_calls"]) for c in self.checks)


@dataclass(frozen=True)
class RunRecord:
    """One kept run: its row, task, verdict, plan outcomes and consultations."""

    row: str
    task: str
    status: str
    plans: dict[str, int]
    consultations: tuple[Consulted, ...]


def read_runs(folder: Path) -> list[RunRecord]:
    """The runs kept under ``folder`` (``bench prompting --keep-runs``), sorted by row and task."""
    out = []
    for loop_file in sorted(folder.glob("*/loop.json")):
        about = json.loads((loop_file.parent / "about.json").read_text())
        loop = json.loads(loop_file.read_text())
        row, task = str(about.get("method", "?")), str(about.get("scenario", "?"))
        consulted = tuple(
            Consulted(row, task, i, tuple(r["checks"]))
            for i, r in enumerate(loop.get("rounds", []), 1)
            if r.get("checks")
        )
        status = str(loop.get("status"))
        out.append(RunRecord(row, task, status, dict(loop.get("plans", {})), consulted))
    return sorted(out, key=lambda r: (r.row, r.task))


def summary_lines(runs: Sequence[RunRecord], walls: dict[tuple[str, str], float]) -> list[str]:
    """Per row: consultations, checks by how they were decided, planner calls, the time of a
    consultation's checks (median, max), plans that ended on a clock, and the slowest run."""
    head = ["row", "runs", "consultations", "checks", *DECIDED_BY, "planner calls"]
    head += ["checks s (median / max)", "plans on a clock", "slowest run s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in sorted({r.row for r in runs}):
        mine = [r for r in runs if r.row == row]
        cons = [c for r in mine for c in r.consultations]
        by = Counter(str(ch["by"]) for c in cons for ch in c.checks)
        secs = [c.seconds for c in cons] or [0.0]
        clock = sum(r.plans.get("timeout", 0) for r in mine)
        slowest = max((walls.get((row, r.task), 0.0) for r in mine), default=0.0)
        cells = [row, str(len(mine)), str(len(cons)), str(sum(by.values()))]
        cells += [str(by.get(b, 0)) for b in DECIDED_BY]
        cells += [str(sum(c.planner_calls for c in cons))]
        cells += [f"{statistics.median(secs):.2f} / {max(secs):.2f}", str(clock), f"{slowest:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def slowest_lines(runs: Sequence[RunRecord]) -> list[str]:
    """The slowest consultations with the goal sets they checked and how each was decided."""
    cons = sorted((c for r in runs for c in r.consultations), key=lambda c: -c.seconds)
    lines = ["| row | task | round | s | planner calls | checks (goals: verdict, by, s) |"]
    lines.append("|---|---|---:|---:|---:|---|")
    for c in cons[:SLOWEST]:
        shown = "; ".join(
            f"{ch['goals']}: {ch['verdict']}, {ch['by']}, {float(ch['seconds']):.2f}"
            for ch in c.checks
        )
        lines.append(
            f"| {c.row} | {c.task} | {c.round} | {c.seconds:.2f} | {c.planner_calls} "
            f"| {shown.replace('|', '/')} |"
        )
    return lines


def wall_times(samples_csv: Path) -> dict[tuple[str, str], float]:
    """Each run's wall time (``bench prompting``'s samples CSV), by row and task."""
    if not samples_csv.is_file():
        return {}
    with samples_csv.open(newline="") as f:
        return {(r["method"], r["task"]): float(r["wall_time"] or 0) for r in csv.DictReader(f)}


def write_csv(runs: Iterable[RunRecord], path: Path) -> Path:
    rows = ["row,task,round,goals,verdict,by,seconds,planner_calls"]
    for r in runs:
        for c in r.consultations:
            for ch in c.checks:
                goals = str(ch["goals"]).replace('"', "'")
                rows.append(
                    f'{r.row},{r.task},{c.round},"{goals}",{ch["verdict"]},{ch["by"]},'
                    f"{ch['seconds']},{ch['planner_calls']}"
                )
    return atomic_write(path, "\n".join(rows) + "\n")


def plot(runs: Sequence[RunRecord], path: Path) -> Path:
    """Per row, each consultation's checking time (log scale) against its checks' count."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for row in sorted({r.row for r in runs}):
        cons = [c for r in runs if r.row == row for c in r.consultations]
        ax.scatter([len(c.checks) for c in cons], [max(c.seconds, 1e-3) for c in cons], label=row)
    ax.set_yscale("log")
    ax.set_xlabel("goal sets checked in the consultation")
    ax.set_ylabel("seconds checking (log)")
    ax.set_title("How long a recovery is checked, per consultation")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def report(out_dir: Path) -> tuple[Path, ...]:
    """recovery.md/.csv/.png from the runs kept under ``out_dir/runs``."""
    runs = read_runs(out_dir / "runs")
    walls = wall_times(out_dir / "prompting_samples.csv")
    slow_runs = sorted(walls.items(), key=lambda kv: -kv[1])[:SLOWEST]
    text = [
        "# How the loop decides a recovery (`llmpas bench recovery`)",
        "",
        "Per row: the consultations' checks by how each was decided (`invariant`: the domain's",
        "invariants, no planner call; `search`: the planner; `limit`: a planner limit, no",
        "verdict), the planner calls, and every plan the runs made that ended on a time limit",
        "(`plans on a clock`: a safety net that fired).",
        "",
        *summary_lines(runs, walls),
        "",
        "## The slowest consultations",
        "",
        *slowest_lines(runs),
        "",
        "## The slowest runs (whole closed loop, wall clock)",
        "",
        "| row | task | s |",
        "|---|---|---:|",
        *(f"| {row} | {task} | {s:.1f} |" for (row, task), s in slow_runs),
        "",
    ]
    md = atomic_write(out_dir / "recovery.md", "\n".join(text))
    return md, write_csv(runs, out_dir / "recovery.csv"), plot(runs, out_dir / "recovery.png")


def add_arguments(p: argparse.ArgumentParser) -> None:
    prompting_arguments(p)
    p.set_defaults(methods=list(CONTROLS), llm="oracle", samples=1)


def config_from(args: argparse.Namespace, shared: Shared) -> PromptingConfig:
    """``bench prompting``'s config, with every run kept."""
    return replace(config_from_args(args, shared), keep_runs=True)


def _run(config: PromptingConfig, console: Console) -> tuple[Path, ...]:
    """``llmpas bench recovery``: the prompting bench with every run kept, then the report."""
    run_prompting(config, console)
    files = report(config.out_dir)
    console.print((config.out_dir / "recovery.md").read_text(), markup=False, highlight=False)
    return files


BENCHMARK = Harnessed(
    "recovery",
    "how each recovery is decided: checks per consultation, how decided, planner calls, time",
    add_arguments,
    config_from,
    _run,
    SHARED,
)

__all__ = ["BENCHMARK", "CONTROLS", "read_runs", "report"]
