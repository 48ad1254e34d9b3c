"""Perturbation benchmark: seeded household episodes with *tolerable* disturbances — pose and
odometry noise, misdetections, a first grasp that slips, the object nudged or moved to the other
part of the same table — executed without any LLM, once with CSubBTs (resampling, backtracking)
and once as a flat plan (every dimension gets one value: no resampling), in one run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from llmpas.files import atomic_write, write_csv
from llmpas.planning import PlannerConfig
from llmpas.worlds.household.decomposition import ExplorationConfig
from llmpas.worlds.household.run import RunConfig, run_scenario
from llmpas.worlds.household.scenario import Scenario

MODES = ("csubbt", "flat")
FLAT = ExplorationConfig(view_bases=1, grasps=1, base_samples=1, max_samples=10)
OBJECTS = ("cube", "apple", "mug")
SOURCES = ("table1_left", "table1_right")
TARGETS = ("table2_left", "table2_right")


@dataclass(frozen=True)
class PerturbationConfig:
    episodes: int = 200
    seed: int = 0
    out_dir: Path = Path("results/perturbation")
    max_time: float = 30.0  # planning limit per episode

    def __post_init__(self) -> None:
        if self.episodes < 1:
            raise ValueError(f"episodes must be >= 1, got {self.episodes}")


@dataclass(frozen=True)
class Outcome:
    episode: int
    mode: str
    disturbances: str
    status: str
    retries: int
    ticks: int
    time: float


def _xy(
    rng: np.random.Generator, rect: tuple[float, float, float, float], m: float = 0.12
) -> tuple[float, float]:
    x0, y0, x1, y1 = rect
    return round(float(rng.uniform(x0 + m, x1 - m)), 3), round(
        float(rng.uniform(y0 + m, y1 - m)), 3
    )


def make_episode(k: int, seed: int) -> tuple[Scenario, str]:
    """Episode ``k``: an object to put into the bowl, with random tolerable disturbances."""
    from llmpas.worlds.household.layout import kitchen

    rng = np.random.default_rng([seed, k])
    layout = kitchen()
    obj = OBJECTS[k % len(OBJECTS)]
    src, dst = SOURCES[int(rng.integers(2))], TARGETS[int(rng.integers(2))]
    ox, oy = _xy(rng, layout.region(src).rect)
    bx, by = _xy(rng, layout.region(dst).rect)
    noise: dict[str, Any] = {
        "pose_sigma": float(rng.uniform(0.0, 0.012)),
        "base_sigma": float(rng.uniform(0.0, 0.01)),
        "miss_prob": float(rng.choice([0.0, 0.1, 0.2])),
    }
    shown = [f"pose {noise['pose_sigma']:.3f}", f"miss {noise['miss_prob']:.1f}"]
    displace: list[dict[str, Any]] = []
    if rng.random() < 0.5:
        displace.append({"kind": "slip", "attempt": 1})
        shown.append("slip")
    if rng.random() < 0.4:
        dx, dy = (float(v) for v in rng.uniform(-0.06, 0.06, size=2))
        displace.append(
            {
                "kind": "nudge",
                "object": obj,
                "dx": round(dx, 3),
                "dy": round(dy, 3),
                "after": {"skill": "move_base", "count": 1},
            }
        )
        shown.append("nudge")
    noise["displace"] = displace
    events = []
    if rng.random() < 0.25:  # moved to the other part of the same table: still tolerable
        other = SOURCES[1 - SOURCES.index(src)]
        x, y = _xy(rng, layout.region(other).rect)
        events.append(
            {
                "after": {"skill": "move_base", "count": 1},
                "type": "move",
                "object": obj,
                "region": other,
                "x": x,
                "y": y,
            }
        )
        shown.append("moved-on-table")
    data = {
        "name": f"perturbation-{k}",
        "seed": int(rng.integers(1 << 30)),
        "noise": noise,
        "objects": [
            {"name": obj, "region": src, "x": ox, "y": oy},
            {"name": "bowl", "region": dst, "x": bx, "y": by},
        ],
        "task": {"goal": f"(On {obj} bowl)"},
        "events": events,
    }
    return Scenario.from_dict(data, source=f"perturbation[{k}]"), "+".join(shown)


def run_episode(k: int, mode: str, config: PerturbationConfig) -> Outcome:
    scenario, shown = make_episode(k, config.seed)
    run = RunConfig(
        planner=PlannerConfig(max_time=config.max_time),
        exploration=ExplorationConfig() if mode == "csubbt" else FLAT,
    )
    py_trees.blackboard.Blackboard.clear()
    r = run_scenario(scenario, run)
    ep = r.episode
    status = ep.status.value if ep is not None else f"plan-{r.plan.status.value}"
    total = r.plan.stats.total_time + (ep.events[-1].t if ep and ep.events else 0.0)
    return Outcome(
        k, mode, shown, status, ep.retries if ep else 0, ep.ticks if ep else 0, round(total, 3)
    )


def summary(outcomes: Sequence[Outcome]) -> str:
    lines = ["| mode | episodes | success rate | mean retries / episode |", "|---|---:|---:|---:|"]
    for mode in MODES:
        mine = [o for o in outcomes if o.mode == mode]
        if not mine:
            continue
        ok = sum(o.status == "success" for o in mine)
        retries = sum(o.retries for o in mine) / len(mine)
        lines.append(f"| {mode} | {len(mine)} | {ok / len(mine):.1%} | {retries:.2f} |")
    return "\n".join(lines) + "\n"


def run_perturbation(
    config: PerturbationConfig, console: Console | None = None
) -> tuple[list[Outcome], list[Path]]:
    console = console or Console()
    outcomes: list[Outcome] = []
    jobs = [(k, m) for k in range(config.episodes) for m in MODES]
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console) as progress:
        task = progress.add_task("perturbation", total=len(jobs))
        for k, mode in jobs:
            progress.update(task, description=f"episode {k} ({mode})")
            outcomes.append(run_episode(k, mode, config))
            progress.advance(task)
    files = _write(outcomes, config)
    console.print(summary(outcomes))
    return outcomes, files


def _write(outcomes: Sequence[Outcome], config: PerturbationConfig) -> list[Path]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    path = out / "perturbation.csv"
    write_csv(path, [asdict(o) for o in outcomes])
    md = out / "perturbation.md"
    atomic_write(
        md,
        f"Perturbation benchmark: {config.episodes} seeded episodes (seed {config.seed}), "
        "no LLM.\n\n" + summary(outcomes),
    )
    return [path, md]
