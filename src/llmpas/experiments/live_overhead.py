"""``llmpas bench live``: what ``run.mcap`` costs. The README's main job (``llmpas run
object-loss --out ...``) runs with and without the Foxglove MCAP sink
(:class:`~llmpas.reporting.live.FoxgloveSink`), alternately, ``--repeats`` times each, with the
same scenario, LLM and seed, each into a run folder of its own; the table gives the median wall
time of each and their ratio, measured in one run, and the time spent inside the sink's calls
(its share of the run), with the MCAP's size and message count and the machine's load average.
The two must give the same rounds and goals, and the MCAP must hold an anomaly and every prompt
of its run, else the benchmark fails."""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from llmpas.experiments.benchmarks import Bench
from llmpas.files import atomic_write


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", default="object-loss", help="a scenario (default: object-loss)")
    p.add_argument("--llm", default="oracle", help="the LLM (default: the labelled oracle)")
    p.add_argument("--repeats", type=int, default=3, help="runs of each, alternately")
    p.add_argument(
        "--scene-period",
        type=float,
        default=None,
        help="seconds between scene updates while a tree ticks (default: the sink's)",
    )
    p.add_argument("--json", help="write the measurements to this JSON file")


class _Timed:
    """An observer that forwards every call to ``inner`` and counts the seconds spent in it."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.seconds = 0.0
        self.calls = 0

    def __getattr__(self, name: str) -> Any:
        method = getattr(self.inner, name)

        def timed(*args: Any) -> Any:
            t = time.perf_counter()
            try:
                return method(*args)
            finally:
                self.seconds += time.perf_counter() - t
                self.calls += 1

        return timed


def _once(
    scenario: str, llm: str, folder: Path, sink: bool, period: float | None
) -> dict[str, Any]:
    from llmpas.reporting.live import SCENE_PERIOD, FoxgloveSink
    from llmpas.system import run
    from llmpas.system.catalog import llm_for, load_world, world_of

    world = world_of(scenario)
    mcap = folder / "run.mcap"
    t0 = time.perf_counter()
    timed = None
    if sink:
        with FoxgloveSink(mcap, scene_period=SCENE_PERIOD if period is None else period) as s:
            timed = _Timed(s)
            result = run(load_world(world), scenario, llm_for(llm, None, world), out=folder,
                         observer=timed)  # fmt: skip
    else:
        result = run(load_world(world), scenario, llm_for(llm, None, world), out=folder)
    wall = time.perf_counter() - t0
    out: dict[str, Any] = {
        "wall": wall,
        "rounds": [r.goal for r in result.rounds],
        "success": result.success,
        "prompts": sum(len(r.proposal.exchanges) for r in result.rounds if r.proposal),
    }
    if timed is not None:
        out |= _contents(mcap) | {"sink": timed.seconds, "sink_calls": timed.calls}
    return out


def _contents(mcap: Path) -> dict[str, Any]:
    """The size of ``mcap``, its messages per topic, its anomalies and prompts."""
    from mcap.reader import make_reader

    topics: dict[str, int] = {}
    prompts = 0
    with mcap.open("rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            if channel.topic == "/llmpas/llm" and json.loads(message.data)["kind"] == "prompt":
                prompts += 1
    return {"bytes": mcap.stat().st_size, "topics": topics, "mcap_prompts": prompts}


def command(args: argparse.Namespace, console: Console) -> int:
    if args.repeats < 1:
        raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
    if args.scene_period is not None and not args.scene_period >= 0:
        raise ValueError(f"--scene-period must be >= 0, got {args.scene_period}")
    load = os.getloadavg()
    runs: dict[str, list[dict[str, Any]]] = {"without": [], "with": []}
    with tempfile.TemporaryDirectory(prefix="llmpas-live-bench-") as tmp:
        for i in range(args.repeats):
            for label in runs:
                folder = Path(tmp) / f"{label}-{i}"
                with console.status(f"{args.scenario} {label} run.mcap ({i + 1}/{args.repeats})"):
                    runs[label].append(
                        _once(args.scenario, args.llm, folder, label == "with", args.scene_period)
                    )
    without = statistics.median(r["wall"] for r in runs["without"])
    with_sink = statistics.median(r["wall"] for r in runs["with"])
    ratio = with_sink / without if without > 0 else float("nan")
    same = all(
        a["rounds"] == b["rounds"] and a["success"] == b["success"]
        for a, b in zip(runs["without"], runs["with"], strict=True)
    )
    complete = all(
        r["topics"].get("/llmpas/anomaly", 0) >= 1 and r["mcap_prompts"] == r["prompts"]
        for r in runs["with"]
    )
    table = Table(title=f"{args.scenario}, --llm {args.llm}: with and without run.mcap")
    for col in ("measure (median)", "without", "with run.mcap", "ratio"):
        table.add_column(col)
    table.add_row("run wall time", f"{without:.2f} s", f"{with_sink:.2f} s", f"{ratio:.3f}x")
    sink = statistics.median(r["sink"] for r in runs["with"])
    table.add_row("in the sink's calls", "", f"{sink * 1000:.1f} ms", f"{sink / with_sink:.2%}")
    console.print(table)
    last = runs["with"][-1]
    console.print(
        f"run.mcap: {last['bytes'] / 1024:.0f} KiB, {sum(last['topics'].values())} messages "
        f"({', '.join(f'{t} {n}' for t, n in sorted(last['topics'].items()))}); "
        f"load average before the runs {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} "
        f"on {os.cpu_count()} CPUs"
    )
    console.print(
        f"rounds and goals {'the same' if same else 'DIFFERENT'} with and without; the MCAP "
        f"{'holds' if complete else 'LACKS'} the anomaly and every prompt"
    )
    if args.json:
        out = {
            "scenario": args.scenario,
            "llm": args.llm,
            "repeats": args.repeats,
            "without": without,
            "with": with_sink,
            "ratio": ratio,
            "sink_seconds": sink,
            "same": same,
            "complete": complete,
            "load": list(load),
            "cpus": os.cpu_count(),
            "runs": runs,
        }
        atomic_write(Path(args.json), json.dumps(out, indent=2))
    return 0 if same and complete else 1


BENCHMARK = Bench(
    "live",
    "the main job's run time with and without run.mcap (the Foxglove sink), as a ratio",
    add_arguments,
    command,
)

__all__ = ["BENCHMARK", "add_arguments", "command"]
