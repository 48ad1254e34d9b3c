"""Perturbation benchmark: seeded household episodes with *tolerable* disturbances — pose and
odometry noise, misdetections, a first grasp that slips, the object nudged or moved to the other
part of the same table — executed without any LLM, once with CSubBTs (resampling, backtracking)
and once as a flat plan (every dimension gets one value: no resampling), in one run.

Each (episode, mode) is a cached job (:mod:`llmpas.experiments.jobs`): an interrupted run
resumes, ``jobs > 1`` runs episodes in parallel processes, and a changed episode or setting never
reuses a stale result. Writes ``perturbation.csv``, ``perturbation.md`` and ``perturbation.png``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
from rich.console import Console

from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions, rows_of, run_trials
from llmpas.experiments.jobs import (
    ExecutorSpec,
    Job,
    fingerprint,
    not_cacheable,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.options import positive_int
from llmpas.options import seed as seed_option
from llmpas.planning import PlannerConfig
from llmpas.system import run_once
from llmpas.worlds.api import RunOptions
from llmpas.worlds.household.household_decomposition import ExplorationConfig
from llmpas.worlds.household.household_plugin import HouseholdPlugin
from llmpas.worlds.household.scenario import Scenario

MODES = ("csubbt", "flat")
FLAT = ExplorationConfig(view_bases=1, grasps=1, base_samples=1, max_samples=10)
OBJECTS = ("cube", "apple", "mug")
SOURCES = ("table1_left", "table1_right")
TARGETS = ("table2_left", "table2_right")
KINDS = ("pose", "miss", "slip", "nudge", "moved-on-table")  # plot order of disturbance kinds


@dataclass(frozen=True)
class PerturbationConfig:
    episodes: int = 200
    seed: int = 0
    out_dir: Path = Path("results/perturbation")
    max_time: float = 30.0  # planning limit per episode
    jobs: int = 1  # parallel processes
    # where the jobs run (local: ``jobs`` processes)
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)

    def __post_init__(self) -> None:
        if self.episodes < 1:
            raise ValueError(f"episodes must be >= 1, got {self.episodes}")
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")


@dataclass(frozen=True)
class Outcome:
    episode: int
    mode: str
    disturbances: str
    status: str
    retries: int
    ticks: int
    time: float


@dataclass(frozen=True)
class Payload:
    """One job: an episode in one mode (picklable: it may run in another process)."""

    episode: int
    mode: str
    config: PerturbationConfig


def _xy(
    rng: np.random.Generator, rect: tuple[float, float, float, float], m: float = 0.12
) -> tuple[float, float]:
    x0, y0, x1, y1 = rect
    return round(float(rng.uniform(x0 + m, x1 - m)), 3), round(
        float(rng.uniform(y0 + m, y1 - m)), 3
    )


def episode_data(k: int, seed: int) -> tuple[dict[str, Any], str]:
    """Episode ``k`` as scenario data (an object to put into the bowl, with random tolerable
    disturbances) and the disturbances shown, joined by ``+``."""
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
    return data, "+".join(shown)


def make_episode(k: int, seed: int) -> tuple[Scenario, str]:
    """Episode ``k``: an object to put into the bowl, with random tolerable disturbances."""
    data, shown = episode_data(k, seed)
    return Scenario.from_dict(data, source=f"perturbation[{k}]"), shown


def run_config(mode: str, config: PerturbationConfig) -> tuple[HouseholdPlugin, RunOptions]:
    """The household world of a mode (how its subtrees explore) and how it runs."""
    world = HouseholdPlugin(exploration=ExplorationConfig() if mode == "csubbt" else FLAT)
    return world, RunOptions(planner=PlannerConfig(max_time=config.max_time))


def run_episode(k: int, mode: str, config: PerturbationConfig) -> Outcome:
    scenario, shown = make_episode(k, config.seed)
    py_trees.blackboard.Blackboard.clear()
    world, options = run_config(mode, config)
    rnd = run_once(world, scenario, options).rounds[0]
    ep = rnd.episode
    status = ep.status.value if ep is not None else f"plan-{rnd.plan.status.value}"
    total = rnd.plan.stats.total_time + (ep.events[-1].t if ep and ep.events else 0.0)
    return Outcome(
        k, mode, shown, status, ep.retries if ep else 0, ep.ticks if ep else 0, round(total, 3)
    )


# ----------------------------------------------------------------------------------- jobs


def run_job(payload: Payload) -> dict[str, Any]:
    """Run one episode in one mode (a module-level function: it may run in another process)."""
    outcome = asdict(run_episode(payload.episode, payload.mode, payload.config))
    if outcome["status"] == "plan-crashed":  # the planner crashed: not an outcome to keep
        return not_cacheable(outcome, "the planner crashed")
    return outcome


def jobs_for(config: PerturbationConfig) -> list[Job[Payload]]:
    """One job per (episode, mode), episode by episode; the key fingerprints the episode's
    scenario data and the run configuration of its mode."""
    out = []
    for k in range(config.episodes):
        data, shown = episode_data(k, config.seed)
        for mode in MODES:
            world, options = run_config(mode, config)
            settings = {"world": asdict(world), "options": asdict(options)}
            digest = fingerprint([config.seed, k, data, shown, mode, settings])
            out.append(
                Job(f"{mode}/seed{config.seed}/episode{k}/{digest}", Payload(k, mode, config))
            )
    return out


def run_perturbation(
    config: PerturbationConfig, console: Console | None = None
) -> tuple[list[Outcome], list[Path]]:
    """Run (or resume) every (episode, mode) not cached yet; write the CSV, table and plot."""
    console = console or Console()
    results = run_trials(config, jobs_for(config), run_job, "perturbation", console)
    outcomes = rows_of(Outcome, results)
    files = _write(outcomes, config)
    console.print(summary(outcomes))
    return outcomes, files


# -------------------------------------------------------------------------------- outputs


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


def kinds(disturbances: str) -> tuple[str, ...]:
    """The disturbance kinds of an episode (``"pose 0.011+miss 0.0+slip"`` -> pose, slip): a
    part with a value is a kind only when the value is not zero."""
    out = []
    for part in disturbances.split("+"):
        name, _, value = part.strip().partition(" ")
        if name and (not value or float(value) != 0.0):
            out.append(name)
    return tuple(out)


def by_kind(outcomes: Sequence[Outcome]) -> dict[str, dict[str, tuple[int, int]]]:
    """Group (``all``, then each disturbance kind present) -> mode -> (successes, episodes)."""
    present = {k for o in outcomes for k in kinds(o.disturbances)}
    order = ["all", *(k for k in KINDS if k in present), *sorted(present - set(KINDS))]
    table: dict[str, dict[str, tuple[int, int]]] = {}
    for group in order:
        table[group] = {}
        for mode in MODES:
            mine = [
                o
                for o in outcomes
                if o.mode == mode and (group == "all" or group in kinds(o.disturbances))
            ]
            table[group][mode] = (sum(o.status == "success" for o in mine), len(mine))
    return table


def plot(outcomes: Sequence[Outcome], config: PerturbationConfig, path: Path) -> None:
    """Grouped bars: success rate of each mode per disturbance kind, episodes per bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = by_kind(outcomes)
    groups = list(table)
    colors = {"csubbt": "tab:blue", "flat": "tab:orange"}
    width = 0.8 / len(MODES)
    fig, ax = plt.subplots(figsize=(max(5.0, 1.3 * len(groups) + 2.0), 4.2))
    for i, mode in enumerate(MODES):
        cells = [table[g][mode] for g in groups]
        xs = [g + (i - (len(MODES) - 1) / 2) * width for g in range(len(groups))]
        rates = [ok / n if n else 0.0 for ok, n in cells]
        bars = ax.bar(xs, rates, width, color=colors[mode], label=mode)
        ax.bar_label(bars, labels=[f"n={n}" for _, n in cells], fontsize=7, padding=2)
    ax.set_xticks(range(len(groups)), groups)
    ax.set_ylim(0.0, 1.25)  # headroom for the labels and the legend
    ax.set_yticks([i / 5 for i in range(6)])
    ax.set_ylabel("success rate")
    ax.set_xlabel("disturbance kind (n = episodes)")
    ax.set_title(
        f"Perturbation: {config.episodes} seeded episodes (seed {config.seed}), no LLM",
        fontsize=10,
    )
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(loc="upper right", ncols=len(MODES), fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


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
    png = out / "perturbation.png"
    plot(outcomes, config, png)
    return [path, md, png]


# ------------------------------------------------------------------------------------ CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench perturbation``."""
    p.add_argument("--episodes", type=positive_int, default=200)
    p.add_argument("--seed", type=seed_option, default=0)


def config_from(args: argparse.Namespace, shared: Shared) -> PerturbationConfig:
    """The config of ``llmpas bench perturbation``'s options."""
    return PerturbationConfig(
        episodes=args.episodes,
        seed=args.seed,
        out_dir=shared.out_dir,
        jobs=shared.jobs,
        executor=shared.executor,
    )


def _run(config: PerturbationConfig, console: Console) -> list[Path]:
    return run_perturbation(config, console)[1]


def _in_all(config: AllConfig) -> tuple[str, ...]:
    episodes = "6" if config.quick else "200"
    return ("--episodes", episodes, *config.jobs_argv(), *config.outputs("perturbation"))


BENCHMARK = Harnessed(
    "perturbation",
    "household episodes with tolerable disturbances: CSubBT vs flat execution, no LLM",
    add_arguments,
    config_from,
    _run,
    SharedOptions(
        out="results/perturbation",
        jobs_help="parallel processes (results cached under OUT/cache)",
        jobs_type=positive_int,
    ),
    _in_all,
)
