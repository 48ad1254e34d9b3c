"""``llmpas bench ros``: what running the loop over ROS 2 costs. The same scenario, LLM and seed
run in-process (the ``pybullet`` world), over ROS 2 (the ``ros2`` world: the robot node in a
process of its own, every skill an action goal, recorded as MCAP) and against the same robot as
a standard ROS 2 robot (``--robot-profile pybullet-standard``: Nav2, ros2_control, TF,
vision_msgs; llmpas plans the arm's trajectories and keeps its own planning scene), alternately,
``--repeats`` times each, none rendering snapshots; the table gives the wall time of each (with
the node's start and the connection for ROS 2), the loop's execution and planning time, and
their ratios to in-process, measured in one run. The ROS 2 run must give the in-process rounds
and goals, else the benchmark fails; whether the standard robot's do is reported."""

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


WORLDS = {"pybullet": None, "ros2": None, "standard": "pybullet-standard"}  # -> robot profile


def _once(label: str, scenario: str, llm: str) -> dict[str, Any]:
    from llmpas.experiments.worlds import LoopConfig, llm_for, run_loop
    from llmpas.worlds.api import RunOptions

    world = "pybullet" if label == "pybullet" else "ros2"
    # no snapshots in any: the robot node renders none, so the in-process run must not
    config = LoopConfig(options=RunOptions(snapshots=False, robot_profile=WORLDS[label]))
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
    runs: dict[str, list[dict[str, Any]]] = {label: [] for label in WORLDS}
    for i in range(args.repeats):
        for label in runs:
            with console.status(f"{args.scenario} on {label} ({i + 1}/{args.repeats}) ..."):
                runs[label].append(_once(label, args.scenario, args.llm))

    def same_as_local(label: str) -> bool:
        return all(
            a["rounds"] == b["rounds"] and a["success"] == b["success"]
            for a, b in zip(runs["pybullet"], runs[label], strict=True)
        )

    same, standard_same = same_as_local("ros2"), same_as_local("standard")
    table = Table(title=f"{args.scenario}, --llm {args.llm}: ROS 2 against in-process")
    for col in ("measure (median)", "in-process", "over ROS 2", "ratio", "standard robot",
                "ratio"):  # fmt: skip
        table.add_column(col)
    summary: dict[str, Any] = {}
    for key, label in (("wall", "run wall time"), ("execute", "execution"), ("plan", "planning")):
        local = statistics.median(r[key] for r in runs["pybullet"])
        ros = statistics.median(r[key] for r in runs["ros2"])
        std = statistics.median(r[key] for r in runs["standard"])
        ratio = ros / local if local > 0 else float("nan")
        std_ratio = std / local if local > 0 else float("nan")
        summary[key] = {
            "in_process": local,
            "ros2": ros,
            "ratio": ratio,
            "standard": std,
            "standard_ratio": std_ratio,
        }
        table.add_row(
            label, f"{local:.2f} s", f"{ros:.2f} s", f"{ratio:.2f}x", f"{std:.2f} s",
            f"{std_ratio:.2f}x",
        )  # fmt: skip
    console.print(table)
    for label, agrees in (("over ROS 2", same), ("standard robot", standard_same)):
        rounds = runs["ros2" if label == "over ROS 2" else "standard"][0]["rounds"]
        console.print(
            f"{label}: rounds and goals {'the same' if agrees else 'DIFFERENT'} as in-process "
            f"({len(rounds)} rounds: {', '.join(rounds)})"
        )
    if args.json:
        out = {
            "scenario": args.scenario,
            "llm": args.llm,
            "same": same,
            "standard_same": standard_same,
            **summary,
            "runs": runs,
        }
        atomic_write(Path(args.json), json.dumps(out, indent=2))
    return 0 if same else 1


BENCHMARK = Bench(
    "ros",
    "run time over ROS 2 against in-process, as a ratio (needs the ros extra)",
    add_arguments,
    command,
)

__all__ = ["BENCHMARK", "add_arguments", "command"]
