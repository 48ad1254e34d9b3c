"""``llmpas bench ros``: what running the loop over ROS 2 costs. The same scenario, LLM and seed
run in-process (the ``pybullet`` world) and over ROS 2 (the ``ros2`` world: the robot node in a
process of its own, every skill an action goal, recorded as MCAP), alternately, ``--repeats``
times each, neither rendering snapshots; the table gives the wall time of each (with the node's
start and the connection for ROS 2), the loop's execution and planning time, and their ratios,
measured in one run. Both runs must give the same rounds and goals, else the benchmark fails."""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from llmpas.experiments.benchmarks import Bench
from llmpas.files import atomic_write


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", default="object-loss", help="a PyBullet scenario")
    p.add_argument("--llm", default="oracle", help="the LLM (default: the labelled oracle)")
    p.add_argument("--repeats", type=int, default=1, help="runs of each, alternately")
    p.add_argument("--json", help="write the measurements to this JSON file")


def _once(world: str, scenario: str, llm: str) -> dict[str, Any]:
    from llmpas.experiments.worlds import LoopConfig, llm_for, run_loop
    from llmpas.worlds.api import RunOptions

    # no snapshots in either: the robot node renders none, so the in-process run must not
    config = LoopConfig(options=RunOptions(snapshots=False))
    t0 = time.perf_counter()
    result = run_loop(scenario, llm_for(llm, None, world), config, world=world)
    wall = time.perf_counter() - t0
    return {
        "wall": wall,
        "execute": float(result.timings.get("execute", 0.0)),
        "plan": float(result.timings.get("plan", 0.0)),
        "rounds": [r.goal for r in result.rounds],
        "success": result.success,
    }


def command(args: argparse.Namespace, console: Console) -> int:
    if args.repeats < 1:
        raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
    runs: dict[str, list[dict[str, Any]]] = {"pybullet": [], "ros2": []}
    for i in range(args.repeats):
        for world in runs:
            with console.status(f"{args.scenario} on {world} ({i + 1}/{args.repeats}) ..."):
                runs[world].append(_once(world, args.scenario, args.llm))
    same = all(
        a["rounds"] == b["rounds"] and a["success"] == b["success"]
        for a, b in zip(runs["pybullet"], runs["ros2"], strict=True)
    )
    table = Table(title=f"{args.scenario}, --llm {args.llm}: ROS 2 against in-process")
    for col in ("measure (median)", "in-process", "over ROS 2", "ratio"):
        table.add_column(col)
    summary: dict[str, Any] = {}
    for key, label in (("wall", "run wall time"), ("execute", "execution"), ("plan", "planning")):
        local = statistics.median(r[key] for r in runs["pybullet"])
        ros = statistics.median(r[key] for r in runs["ros2"])
        ratio = ros / local if local > 0 else float("nan")
        summary[key] = {"in_process": local, "ros2": ros, "ratio": ratio}
        table.add_row(label, f"{local:.2f} s", f"{ros:.2f} s", f"{ratio:.2f}x")
    console.print(table)
    rounds = runs["ros2"][0]["rounds"]
    console.print(
        f"rounds and goals {'the same' if same else 'DIFFERENT'} ({len(rounds)} rounds: "
        f"{', '.join(rounds)})"
    )
    if args.json:
        out = {"scenario": args.scenario, "llm": args.llm, "same": same, **summary, "runs": runs}
        atomic_write(Path(args.json), json.dumps(out, indent=2))
    return 0 if same else 1


BENCHMARK = Bench(
    "ros",
    "run time over ROS 2 against in-process, as a ratio (needs the ros extra)",
    add_arguments,
    command,
)

__all__ = ["BENCHMARK", "add_arguments", "command"]
