"""Scenarios of the PyBullet world and their execution without any LLM: belief -> problem ->
plan -> CSubBTs -> episode (-> an episode folder with the report, snapshots, a GIF, CSubBT XML).

The simulator's true state is used only to build the world, to fire scenario events and to judge
the outcome afterwards.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.context import Belief, Context, Recorder
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode, ExecutorConfig, execute
from llmpas.execution.report import save_episode
from llmpas.files import atomic_write
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig, PlanResult, solve
from llmpas.worlds.pybullet.camera import CameraConfig
from llmpas.worlds.pybullet.decomposition import ExplorationConfig, build_specs
from llmpas.worlds.pybullet.problem import initial_belief, make_problem
from llmpas.worlds.pybullet.scene import TABLE_TOP, ObjectConfig, Scene, SceneConfig, open_client
from llmpas.worlds.pybullet.snapshot import save_media
from llmpas.worlds.pybullet.streams import Geometry
from llmpas.worlds.pybullet.values import BaseConf, ObjectPose
from llmpas.worlds.pybullet.world import Event, PyBulletWorld

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Scenario:
    """A world, what the robot believes, a goal, and what happens behind the robot's back."""

    name: str
    description: str
    scene: SceneConfig
    goal: str
    seed: int = 0
    inside: tuple[tuple[str, str], ...] = ()  # (object, bowl): starts inside the bowl
    unknown: tuple[str, ...] = ()  # objects the robot does not know the whereabouts of
    events: tuple[Event, ...] = ()
    belief_noise: float = 0.0  # metres: error of the believed initial object positions
    event_jitter: float = 0.0  # metres: seeded spread of where events put objects

    def __post_init__(self) -> None:
        names = {o.name for o in self.scene.objects}
        for obj, bowl in self.inside:
            if obj not in names or bowl not in names:
                raise ValueError(f"scenario {self.name!r}: unknown object in {(obj, bowl)}")
        for n in (*self.unknown, *(e.obj for e in self.events)):
            if n not in names:
                raise ValueError(f"scenario {self.name!r}: unknown object {n!r}")
        if self.belief_noise < 0 or self.event_jitter < 0:
            raise ValueError("belief_noise and event_jitter must be >= 0")

    def seeded_events(self, rng: np.random.Generator) -> tuple[Event, ...]:
        """The events, their drop points spread by ``event_jitter`` (clipped to stay on the
        table, 12 cm from its edges)."""
        if not self.event_jitter:
            return self.events
        out = []
        for e in self.events:
            t = self.scene.table(e.table)
            half = (0.5, 0.75) if abs(math.sin(t.yaw)) > 0.5 else (0.75, 0.5)
            dx, dy = rng.normal(0.0, self.event_jitter, 2)
            out.append(
                replace(
                    e,
                    dx=float(np.clip(e.dx + dx, -half[0] + 0.12, half[0] - 0.12)),
                    dy=float(np.clip(e.dy + dy, -half[1] + 0.12, half[1] - 0.12)),
                )
            )
        return tuple(out)


def _objects(*extra: ObjectConfig) -> tuple[ObjectConfig, ...]:
    return (
        ObjectConfig("cube", "cube", "table1", -0.33, 0.15, "green"),
        ObjectConfig("bowl", "bowl", "table2", -0.1, -0.3, "white", 0.16),
        *extra,
    )


def scenarios() -> dict[str, Scenario]:
    goal = "(and (On cube bowl))"
    blocker = ObjectConfig("black_cube", "cube", "table2", 0.5, 0.3, "black")
    return {
        s.name: s
        for s in (
            Scenario(
                "nominal",
                "Put the green cube from table1 into the bowl on table2. Tolerable disturbances: "
                "odometry and detection noise, believed positions off by a few centimetres, and "
                "the cube nudged on its table while the robot drives.",
                SceneConfig(objects=_objects()),
                goal,
                seed=0,
                events=(Event("move_base", 1, "cube", "table1", -0.3, 0.1),),
                belief_noise=0.02,
                event_jitter=0.08,
            ),
            Scenario(
                "object-loss",
                "Object loss: while the robot drives to table1 for the cube, someone moves the "
                "cube to table2. The robot still believes it is on table1.",
                SceneConfig(objects=_objects()),
                goal,
                seed=2,
                events=(Event("move_base", 1, "cube", "table2", 0.35, -0.3),),
                event_jitter=0.08,
            ),
            Scenario(
                "action-blocking",
                "Action blocking: put the green cube into the bowl. The bowl already holds the "
                "black cube, which the robot does not know about; the bowl holds one object.",
                SceneConfig(objects=_objects(blocker)),
                goal,
                seed=6,
                inside=(("black_cube", "bowl"),),
                unknown=("black_cube",),
            ),
        )
    }


@dataclass(frozen=True)
class RunConfig:
    planner: PlannerConfig = field(default_factory=lambda: PlannerConfig(max_time=60.0))
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    executor: ExecutorConfig = field(default_factory=ExecutorConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    seed: int | None = None  # None: the scenario's own seed
    snapshots: bool = True
    gui: bool = False


@dataclass(frozen=True)
class PyBulletRun:
    scenario: Scenario
    plan: PlanResult
    specs: tuple[SubtreeSpec, ...]
    episode: Episode | None
    achieved: bool  # the goal holds in the simulator's true state (judged afterwards)
    timings: dict[str, float]
    log: tuple[str, ...] = ()
    problem: Problem | None = field(default=None, repr=False)

    @property
    def succeeded(self) -> bool:
        return self.episode is not None and self.episode.succeeded and self.achieved


def setup_scene(scene: Scene, scenario: Scenario) -> None:
    for obj, bowl in scenario.inside:
        at, _ = scene.pose(bowl)
        size = scene.config.obj(obj).size
        scene.set_pose(obj, (float(at[0]), float(at[1]), TABLE_TOP + 0.01 + size / 2 + 0.003))
    scene.settle(120)


def belief_for(scene: Scene, scenario: Scenario, rng: np.random.Generator) -> Belief:
    """The robot's initial belief: where it was told the objects are (the initial layout, with
    ``belief_noise``), nothing about the ``unknown`` ones."""
    poses: dict[str, ObjectPose | None] = {}
    for o in scene.config.objects:
        if o.name in scenario.unknown:
            continue
        rect = scene.tables[o.table]
        cx, cy = rect.center
        dx, dy = rng.normal(0.0, scenario.belief_noise, 2) if scenario.belief_noise else (0, 0)
        z = TABLE_TOP + (o.size / 2 if o.kind == "cube" else 0.0)
        poses[o.name] = ObjectPose(
            o.table, round(cx + o.dx + float(dx), 3), round(cy + o.dy + float(dy), 3), z
        )
    x, y, t = scene.config.base
    return initial_belief(scene.config, poses, BaseConf(x, y, t))


def goal_holds(scene: Scene, goal: str) -> bool:
    """Judge the scenario goal ``(On cube bowl)`` in the true state (cube resting inside)."""
    if "(on cube bowl)" not in goal.lower():
        raise ValueError(f"cannot judge goal {goal!r}")
    if scene.held == "cube":
        return False
    cube, _ = scene.pose("cube")
    bowl, _ = scene.pose("bowl")
    inner = scene.config.obj("bowl").size / 2 - 0.01
    inside = abs(cube[0] - bowl[0]) < inner and abs(cube[1] - bowl[1]) < inner
    return bool(inside and cube[2] < bowl[2] + 0.08)


class Session:
    """One scenario's simulation, belief and execution context, across planning rounds."""

    def __init__(self, scenario: Scenario, config: RunConfig, client: int) -> None:
        self.scenario = scenario
        self.config = config
        self.seed = scenario.seed if config.seed is None else config.seed
        self.timings: dict[str, float] = {}
        t0 = time.perf_counter()
        self.scene = Scene(client, scenario.scene)
        setup_scene(self.scene, scenario)
        self.timings["build"] = time.perf_counter() - t0
        self.world = PyBulletWorld(
            self.scene,
            np.random.default_rng([self.seed, 0]),
            config.camera,
            scenario.seeded_events(np.random.default_rng([self.seed, 4])),
            snapshots=config.snapshots,
        )
        self.belief = belief_for(self.scene, scenario, np.random.default_rng([self.seed, 3]))
        self.geometry = Geometry(self.scene, np.random.default_rng([self.seed, 1]))
        self.ctx = Context(
            self.world, self.world, self.belief, np.random.default_rng([self.seed, 2])
        )
        self.rounds = 0
        self.world.clock = lambda: (self.rounds, len(self.ctx.recorder.events))

    def sync_base(self) -> None:
        """Believe the base is where odometry says (after a failed subtree drove around)."""
        here = self.world.base_conf()
        old = self.belief.matching("atbconf")
        current = self.belief.values.get(old[0].args[0]) if old else None
        if isinstance(current, BaseConf) and current.distance(here) < 1e-6:
            return
        self.belief.facts -= set(old)
        q = self.belief.name("q", here)
        self.belief.facts |= {Atom("bconf", (q,)), Atom("atbconf", (q,))}

    def plan(self, goal: Formula | str) -> tuple[PlanResult, Problem]:
        self.sync_base()
        problem = make_problem(self.geometry, self.belief, goal, here=self.world.base_conf())
        t = time.perf_counter()
        result = solve(problem, self.config.planner)
        self.timings["plan"] = self.timings.get("plan", 0.0) + time.perf_counter() - t
        return result, problem

    def execute(
        self, result: PlanResult, problem: Problem
    ) -> tuple[tuple[SubtreeSpec, ...], Episode | None]:
        if result.plan is None:
            return (), None
        specs = tuple(build_specs(self.scene.config, problem, result.plan, self.config.exploration))
        self.ctx.recorder = Recorder()
        t = time.perf_counter()
        episode = execute(specs, self.ctx, self.config.executor)
        self.timings["execute"] = self.timings.get("execute", 0.0) + time.perf_counter() - t
        self.rounds += 1
        return specs, episode

    def achieved(self) -> bool:
        return goal_holds(self.scene, self.scenario.goal)


def resolve(scenario: Scenario | str) -> Scenario:
    if isinstance(scenario, Scenario):
        return scenario
    known = scenarios()
    if scenario not in known:
        raise KeyError(f"no scenario {scenario!r}; known: {', '.join(sorted(known))}")
    return known[scenario]


def run_scenario(
    scenario: Scenario | str, config: RunConfig | None = None, out: str | Path | None = None
) -> PyBulletRun:
    """Plan once and execute (no LLM); judge the goal in the true state afterwards."""
    config = config or RunConfig()
    scenario = resolve(scenario)
    t0 = time.perf_counter()
    with open_client(config.gui) as cid:
        session = Session(scenario, config, cid)
        result, problem = session.plan(scenario.goal)
        specs, episode = session.execute(result, problem)
        if episode is not None:
            session.world.snapshot(f"end: {episode.status.value}")
        timings = dict(session.timings, total=time.perf_counter() - t0)
        run = PyBulletRun(
            scenario,
            result,
            specs,
            episode,
            session.achieved(),
            timings,
            tuple(session.world.log),
            problem,
        )
        if out is not None:
            save_run(run, session.world, out)
    return run


def save_run(run: PyBulletRun, world: PyBulletWorld, folder: str | Path) -> list[Path]:
    """The episode folder: episode.json, report.md/html, CSubBT XML, snapshots, a GIF."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    if run.episode is not None:
        written += save_episode(run.episode, folder, run.specs, f"PyBullet: {run.scenario.name}")
    written += save_media(world.frames, world.images, folder)
    summary: dict[str, Any] = {
        "scenario": run.scenario.name,
        "succeeded": run.succeeded,
        "achieved": run.achieved,
        "timings": {k: round(v, 3) for k, v in run.timings.items()},
        "world_log": list(run.log),
    }
    written.append(atomic_write(folder / "run.json", json.dumps(summary, indent=2)))
    return written


__all__ = [
    "PyBulletRun",
    "RunConfig",
    "Scenario",
    "Session",
    "goal_holds",
    "run_scenario",
    "scenarios",
]
