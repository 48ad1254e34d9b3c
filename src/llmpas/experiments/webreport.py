"""``llmpas bench report``: how big the main job's web report is and how long it takes to build
(targets: under 5 MB, under 2 s). A benchmark, not a test: it runs the main job once
(``llmpas run object-loss --llm oracle --with-replan``, or reads a given run folder) and builds
its page ``--repeats`` times, reporting the median and the largest build time."""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
from pathlib import Path

from rich.console import Console
from rich.table import Table

from llmpas.experiments.benchmarks import Bench
from llmpas.reporting import Built, build_report

SIZE_TARGET = 5_000_000  # bytes
TIME_TARGET = 2.0  # seconds


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--run", help="a run folder (default: run the main job with the oracle)")
    p.add_argument("--repeats", type=int, default=5, help="page builds timed")


def _main_job(folder: Path, console: Console) -> Path:
    """``llmpas run object-loss --llm oracle --with-replan --out FOLDER/object-loss``, without
    its page (the replan-only run of the same scenario and seed in ``replan-only``)."""
    from llmpas.experiments.worlds import run_loop
    from llmpas.files import atomic_write
    from llmpas.reasoning.truth_oracle import ORACLE
    from llmpas.system.catalog import llm_for

    out = folder / "object-loss"
    with console.status("running the main job (object-loss, oracle, and replan only) ..."):
        run_loop("object-loss", ORACLE, out=out)
        run_loop("object-loss", llm_for("replan", world="pybullet"), out=out / "replan-only")
    atomic_write(out / "about.json", json.dumps({"llm": ORACLE, "baseline": "replan-only"}))
    return out


def measure(folder: Path, repeats: int) -> list[Built]:
    return [build_report(folder) for _ in range(repeats)]


def command(args: argparse.Namespace, console: Console) -> int:
    if args.repeats < 1:
        raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
    with tempfile.TemporaryDirectory(prefix="llmpas-bench-report-") as tmp:
        folder = Path(args.run) if args.run else _main_job(Path(tmp), console)
        if not folder.is_dir():
            raise ValueError(f"--run {folder}: no such folder")
        builds = measure(folder, args.repeats)
        images = sum(1 for p in folder.rglob("*") if p.suffix in (".png", ".gif", ".jpg"))
    size = builds[-1].bytes
    times = [b.seconds for b in builds]
    median = statistics.median(times)
    table = Table(title=f"web report of {folder.name} ({images} images in the folder)")
    for col in ("measure", "value", "target", "ok"):
        table.add_column(col)
    mb = f"< {SIZE_TARGET / 1e6:.0f} MB"
    table.add_row("page size", f"{size / 1e6:.2f} MB", mb, _ok(size < SIZE_TARGET))
    label = f"build time (median of {len(times)})"
    table.add_row(label, f"{median:.3f} s", f"< {TIME_TARGET:.0f} s", _ok(median < TIME_TARGET))
    table.add_row("build time (largest)", f"{max(times):.3f} s", "", "")
    console.print(table)
    return 0


def _ok(good: bool) -> str:
    return "yes" if good else "NO"


BENCHMARK = Bench(
    "report", "size and build time of the main job's web report", add_arguments, command
)

__all__ = ["BENCHMARK", "SIZE_TARGET", "TIME_TARGET", "add_arguments", "command", "measure"]
