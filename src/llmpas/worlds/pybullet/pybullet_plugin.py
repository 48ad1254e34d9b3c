"""The PyBullet world (a Husky + Franka Panda) as a plug-in (:class:`llmpas.worlds.api.World`):
its scenarios, and a session per scenario in its own physics client holding the scene, the
simulated robot and camera, the belief and the parts the loop asks for. Planning, execution and
reasoning live in :mod:`llmpas.system`."""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import ExecutorConfig
from llmpas.language.domain import Domain
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.planning.result import Plan
from llmpas.reasoning.tables import PromptTables, Vocabulary
from llmpas.worlds.api import RunOptions, SceneView, holds
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.kitchen.kitchen_session import PLANNER, KitchenSearch, KitchenSession
from llmpas.worlds.pybullet.camera import CameraConfig
from llmpas.worlds.pybullet.pybullet_decomposition import ExplorationConfig, build_specs, table_of
from llmpas.worlds.pybullet.pybullet_problem import believe_base, make_problem
from llmpas.worlds.pybullet.pybullet_reasoning import environment, prompt_tables, vocabulary
from llmpas.worlds.pybullet.pybullet_robot import PyBulletWorld
from llmpas.worlds.pybullet.pybullet_scenarios import (
    PyBulletScenario,
    belief_for,
    resolve,
    save_world,
    scenarios,
    setup_scene,
    true_facts,
)
from llmpas.worlds.pybullet.pybullet_streams import Geometry
from llmpas.worlds.pybullet.pybullet_values import ObjectPose
from llmpas.worlds.pybullet.scene import Scene, SceneConfig, open_client
from llmpas.worlds.pybullet.view import scene_view


def table_search(config: SceneConfig, belief: Belief) -> KitchenSearch:
    """Searching in the PyBullet world: drive to a table and look at it; a failed detection
    looked at the table of the region it expected the object on (a bowl's table)."""

    def looked_at(report: AnomalyReport) -> tuple[str, ...]:
        c = report.constraint
        if not isinstance(c, Atom) or len(c.args) < 2:
            return ()
        return (table_of(config, belief, c.args[1]),)

    tables = tuple(t.name for t in config.tables)
    known = frozenset(o.name for o in config.objects)
    return KitchenSearch(belief, tables, known, ObjectPose, looked_at)


class PyBulletSession(KitchenSession):
    """One scenario's simulation, belief and execution context, across planning rounds."""

    scenario: PyBulletScenario

    def __init__(
        self, scenario: PyBulletScenario, plugin: PyBulletPlugin, options: RunOptions, client: int
    ):
        self.scenario = scenario
        self.seed = scenario.seed if options.seed is None else options.seed
        self.planner = options.planner or PLANNER
        self.executor = options.executor or ExecutorConfig()
        self.exploration = plugin.exploration
        self.timings: dict[str, float] = {}
        t0 = time.perf_counter()
        self.scene = Scene(client, scenario.scene)
        setup_scene(self.scene, scenario)
        self.timings["build"] = time.perf_counter() - t0
        self.world = PyBulletWorld(
            self.scene,
            np.random.default_rng([self.seed, 0]),
            plugin.camera,
            scenario.seeded_events(np.random.default_rng([self.seed, 4])),
            snapshots=options.snapshots,
        )
        belief = belief_for(self.scene, scenario, np.random.default_rng([self.seed, 3]))
        self.geometry = Geometry(self.scene, np.random.default_rng([self.seed, 1]))
        self.context = Context(
            self.world, self.world, belief, np.random.default_rng([self.seed, 2])
        )
        self.domain: Domain = load_domain()
        self.vocabulary: Vocabulary = vocabulary(scenario.scene)
        self.prompts: PromptTables = prompt_tables(scenario.scene)
        self.search = table_search(scenario.scene, belief)
        self.rounds = 0  # the episode running (for the marks of snapshots)
        self.episodes = 0
        self.world.clock = lambda: (self.rounds, len(self.context.recorder.events))

    def sync_base(self) -> None:
        """Believe the base is where odometry says (after a failed subtree drove around)."""
        believe_base(self.belief, self.world.base_conf())

    def problem(self, goal: Formula | str, index: int) -> Problem:
        self.sync_base()
        return make_problem(self.geometry, self.belief, goal, here=self.world.base_conf())

    def decompose(self, problem: Problem, plan: Plan) -> Sequence[SubtreeSpec]:
        self.rounds, self.episodes = self.episodes, self.episodes + 1
        return build_specs(self.scene.config, problem, plan, self.exploration)

    def environment(self) -> str:
        return environment(self.scenario.scene, self.belief)

    def scene_view(self) -> SceneView:
        """Tables, objects believed and true, the robot's frames (a viewer's; docs/live.md)."""
        return scene_view(self.scene, self.belief)

    def true_facts(self) -> frozenset[Atom]:
        """The simulator's true state, as facts (for the truth judge only)."""
        return true_facts(self.scene)

    def achieved(self) -> bool:
        """The task judged in the simulator's true state."""
        return holds(self.task, self.true_facts())

    def save(self, folder: Path) -> list[Path]:
        self.rounds = self.episodes
        self.world.snapshot("end")
        about = {"scenario": self.name, "achieved": self.achieved(), "timings": self.timings}
        return save_world(self.world, folder, about)


@dataclass(frozen=True)
class PyBulletPlugin:
    """The PyBullet world (``camera``, ``exploration``: how it senses and explores)."""

    camera: CameraConfig = field(default_factory=CameraConfig)
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    name: str = "pybullet"
    title: str = "PyBullet: Husky + Franka Panda"

    def scenarios(self) -> dict[str, str]:
        return {name: s.description for name, s in scenarios().items()}

    @contextmanager
    def open(self, scenario: Any, options: RunOptions) -> Iterator[PyBulletSession]:
        """``scenario``: a :class:`PyBulletScenario` or a shipped name (KeyError naming the
        known)."""
        scenario = resolve(scenario)
        with open_client(options.gui) as client:
            yield PyBulletSession(scenario, self, options, client)


WORLD = PyBulletPlugin()

__all__ = ["WORLD", "PyBulletPlugin", "PyBulletSession", "table_search"]
