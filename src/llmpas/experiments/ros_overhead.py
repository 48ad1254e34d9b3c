"""``llmpas bench ros``: what running the loop over ROS 2 costs. The same scenario, LLM and seed
run in-process (the ``pybullet`` world), over ROS 2 (the ``ros2`` world: the robot node in a
process of its own, every skill an action goal, recorded as MCAP) and against the same robot as
a standard ROS 2 robot (``--robot-profile pybullet-standard``: Nav2, ros2_control, TF,
vision_msgs; llmpas plans the arm's trajectories and keeps its own planning scene) and that
standard robot driven from a site file alone (``--site``: the planning scene from the site and
the robot's description; its verdict is what it perceived), alternately,
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
    p.add_argument(
        "--site",
        default="house",
        help="the site for the standard robot driven from a site (a file or a shipped name; "
        "the scenario is one of its tasks; '': no such row)",
    )
    p.add_argument("--json", help="write the measurements to this JSON file")


WORLDS = {  # -> robot profile
    "pybullet": None,
    "ros2": None,
    "standard": "pybullet-standard",
    "site": "pybullet-standard",
}


def _once(label: str, scenario: str, llm: str, site: str = "") -> dict[str, Any]:
    from llmpas.experiments.worlds import LoopConfig, run_loop
    from llmpas.system.catalog import llm_for
    from llmpas.worlds.api import RunOptions

    world = "pybullet" if label == "pybullet" else "ros2"
    # no snapshots in any: the robot node renders none, so the in-process run must not
    options = RunOptions(
        snapshots=False, robot_profile=WORLDS[label], site=site if label == "site" else None
    )
    config = LoopConfig(options=options)
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
    labels = [label for label in WORLDS if label != "site" or args.site]
    runs: dict[str, list[dict[str, Any]]] = {label: [] for label in labels}
    for i in range(args.repeats):
        for label in runs:
            with console.status(f"{args.scenario} on {label} ({i + 1}/{args.repeats}) ..."):
                runs[label].append(_once(label, args.scenario, args.llm, args.site))

    def same_as_local(label: str) -> bool:
        return all(
            a["rounds"] == b["rounds"] and a["success"] == b["success"]
            for a, b in zip(runs["pybullet"], runs[label], strict=True)
        )

    same, standard_same = same_as_local("ros2"), same_as_local("standard")
    names = {"ros2": "over ROS 2", "standard": "standard robot", "site": "standard + site"}
    others = [label for label in runs if label != "pybullet"]
    table = Table(title=f"{args.scenario}, --llm {args.llm}: ROS 2 against in-process")
    table.add_column("measure (median)")
    table.add_column("in-process")
    for label in others:
        table.add_column(names[label])
        table.add_column("ratio")
    summary: dict[str, Any] = {}
    keys = {"ros2": ("ros2", "ratio"), "standard": ("standard", "standard_ratio"),
            "site": ("site", "site_ratio")}  # fmt: skip
    for key, label in (("wall", "run wall time"), ("execute", "execution"), ("plan", "planning")):
        local = statistics.median(r[key] for r in runs["pybullet"])
        row = [label, f"{local:.2f} s"]
        summary[key] = {"in_process": local}
        for other in others:
            value = statistics.median(r[key] for r in runs[other])
            ratio = value / local if local > 0 else float("nan")
            summary[key].update({keys[other][0]: value, keys[other][1]: ratio})
            row += [f"{value:.2f} s", f"{ratio:.2f}x"]
        table.add_row(*row)
    console.print(table)
    for label in others:
        rounds = runs[label][0]["rounds"]
        agrees = same_as_local(label)
        done = "task done" if all(r["success"] for r in runs[label]) else "NOT ALL DONE"
        basis = " (perceived)" if label == "site" else ""
        console.print(
            f"{names[label]}: rounds and goals {'the same' if agrees else 'DIFFERENT'} as "
            f"in-process ({len(rounds)} rounds: {', '.join(rounds)}); {done}{basis}"
        )
    if args.json:
        out = {
            "scenario": args.scenario,
            "llm": args.llm,
            "same": same,
            "standard_same": standard_same,
            "site": args.site,
            "site_same": same_as_local("site") if "site" in runs else None,
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
