"""The tabletop world as a :class:`llmpas.worlds.api.World`: PyBullet's parts, a fixed arm.

Everything physical is the PyBullet world's (scene, skills, cameras, streams, decomposition,
the Robot/Perception adapter); this module only pins the base: every base pose a stream
proposes is the one the Panda stands at, placements are sampled where the arm reaches, and a
drive exists only to where the robot already is.
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

from llmpas.execution.context import Belief, Context, Recorder
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import ExecutorConfig
from llmpas.files import atomic_write
from llmpas.language.domain import Domain
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig
from llmpas.planning.result import Plan
from llmpas.reasoning.tables import PromptTables, Vocabulary
from llmpas.worlds.api import RunOptions, SceneView, holds
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.kitchen.kitchen_reasoning import whereabouts
from llmpas.worlds.kitchen.kitchen_session import KitchenSession
from llmpas.worlds.pybullet.pybullet_decomposition import build_specs
from llmpas.worlds.pybullet.pybullet_motion import BaseChecker
from llmpas.worlds.pybullet.pybullet_plugin import table_search
from llmpas.worlds.pybullet.pybullet_problem import believed_pose, initial_belief, make_problem
from llmpas.worlds.pybullet.pybullet_reasoning import vocabulary as make_vocabulary
from llmpas.worlds.pybullet.pybullet_robot import PyBulletWorld
from llmpas.worlds.pybullet.pybullet_scenarios import true_facts
from llmpas.worlds.pybullet.pybullet_streams import Geometry
from llmpas.worlds.pybullet.pybullet_values import BaseConf, BasePath, Grasp, ObjectPose
from llmpas.worlds.pybullet.scene import TABLE_TOP, Rect, Scene, open_client
from llmpas.worlds.pybullet.snapshot import save_media
from llmpas.worlds.pybullet.view import scene_view
from llmpas.worlds.tabletop.scenarios import WORKSPACE, TabletopScenario, prompt_tables, scenarios


class FixedGeometry(Geometry):
    """The planning model of an arm that cannot move its base."""

    def __init__(self, scene: Scene, rng: np.random.Generator, workspace: Rect) -> None:
        super().__init__(scene, rng)
        self.base = BaseConf(*scene.config.base)
        self.workspace = workspace
        self.checker = BaseChecker((), Rect(-1e3, -1e3, 1e3, 1e3))  # the base never moves

    def placements(self, obj: str, table: str) -> Iterator[ObjectPose]:
        """Spots on ``table`` inside the workspace that a top grasp reaches (bounded tries)."""
        w, size = self.workspace, self.scene.config.obj(obj).size
        for _ in range(self.config.kin_samples * 8):
            x, y = self.rng.uniform(w.x0, w.x1), self.rng.uniform(w.y0, w.y1)
            pose = ObjectPose(table, round(float(x), 3), round(float(y), 3), TABLE_TOP + size / 2)
            if self.scene.tables[table].contains(x, y, 0.1) and self.reaches(
                self.base, pose, Grasp("top"), size
            ):
                yield pose

    def kin(self, obj: str, pose: ObjectPose, grasp: Grasp) -> Iterator[BaseConf]:
        if self.reaches(self.base, pose, grasp, self.scene.config.obj(obj).size):
            yield self.base

    def views(self, table: str, near: tuple[float, float] | None) -> Iterator[BaseConf]:
        yield self.base

    def drive(self, q1: BaseConf, q2: BaseConf) -> BasePath | None:
        return BasePath((q1.pose,)) if q1.distance(q2) < 1e-3 else None


class TabletopSession(KitchenSession):
    """One scenario in one physics client; its belief carries over between rounds."""

    scenario: TabletopScenario

    def __init__(self, scenario: TabletopScenario, options: RunOptions, client: int) -> None:
        t0 = time.perf_counter()
        self.scenario = scenario
        seed = scenario.seed if options.seed is None else options.seed
        self.scene = Scene(client, scenario.scene)
        for obj, bowl in scenario.inside:
            at, _ = self.scene.pose(bowl)
            z = TABLE_TOP + 0.013 + self.scene.config.obj(obj).size / 2
            self.scene.set_pose(obj, (float(at[0]), float(at[1]), z))
        self.scene.settle(120)
        self.world = PyBulletWorld(
            self.scene, np.random.default_rng([seed, 0]), snapshots=options.snapshots
        )
        belief = self._initial_belief()
        self.geometry = FixedGeometry(self.scene, np.random.default_rng([seed, 1]), WORKSPACE)
        self.context = Context(self.world, self.world, belief, np.random.default_rng([seed, 2]))
        self.planner = options.planner or PlannerConfig.validation(seed=seed)
        self.executor = options.executor or ExecutorConfig()
        self.search = table_search(scenario.scene, belief)  # searching is looking at a table
        self.domain: Domain = load_domain()
        self.vocabulary: Vocabulary = make_vocabulary(scenario.scene)
        self.prompts: PromptTables = prompt_tables(scenario.scene)
        self.episodes = 0
        self.world.clock = lambda: (max(self.episodes - 1, 0), len(self.context.recorder.events))
        self.timings: Mapping[str, float] = {"build": time.perf_counter() - t0}

    def _initial_belief(self) -> Belief:
        """Where the robot is told the objects are (their start), nothing about unknown ones."""
        poses: dict[str, ObjectPose | None] = {}
        for o in self.scene.config.objects:
            if o.name not in self.scenario.unknown:
                at, _ = self.scene.pose(o.name)
                z = TABLE_TOP + (o.size / 2 if o.kind == "cube" else 0.0)
                poses[o.name] = ObjectPose(
                    o.table, round(float(at[0]), 3), round(float(at[1]), 3), z
                )
        belief = initial_belief(self.scene.config, poses, BaseConf(*self.scene.config.base))
        # a bowl (16 cm) is wider than the gripper opens (8 cm): a fixture, not an object to pick
        bowls = {o.name for o in self.scene.config.objects if o.kind == "bowl"}
        belief.facts -= {Atom.of("Object", b) for b in bowls}
        return belief

    def scene_view(self) -> SceneView:
        """The table, the objects believed and true, the arm's base and gripper (a viewer's)."""
        return scene_view(self.scene, self.belief)

    def problem(self, goal: Formula | str, index: int) -> Problem:
        return make_problem(self.geometry, self.belief, goal, here=self.geometry.base)

    def decompose(self, problem: Problem, plan: Plan) -> Sequence[SubtreeSpec]:
        self.episodes += 1
        self.context.recorder = Recorder()  # one episode's events
        return build_specs(self.scene.config, problem, plan)

    def environment(self) -> str:
        lines = []
        for o in self.scene.config.objects:
            pose = believed_pose(self.belief, o.name)
            where = whereabouts(self.belief, o.name, pose, "the arm")
            lines.append(f"- {o.name} ({o.colour} {o.kind}): {where}")
        lines.append(f"- tables: {', '.join(self.scene.tables)} (the arm stands fixed at it)")
        return "\n".join(lines)

    def true_facts(self) -> frozenset[Atom]:
        """PyBullet's true state, as facts (for the truth judge only)."""
        return true_facts(self.scene)

    def achieved(self) -> bool:
        """Every ``(on O R)`` of the task holds in PyBullet's true state (O at rest in R)."""
        return holds(self.task, self.true_facts())

    def save(self, folder: Path) -> list[Path]:
        self.world.snapshot("end")
        written = save_media(self.world.frames, self.world.images, folder)
        log = {"scenario": self.name, "achieved": self.achieved(), "world_log": self.world.log}
        return [*written, atomic_write(folder / "world.json", json.dumps(log, indent=2))]


class TabletopWorld:
    """The plug-in: ``tabletop-nominal`` and ``tabletop-blocking``."""

    name = "tabletop"
    title = "PyBullet tabletop: a fixed Franka Panda"

    def scenarios(self) -> Mapping[str, str]:
        return {n: s.description for n, s in scenarios().items()}

    @contextlib.contextmanager
    def open(self, scenario: str, options: RunOptions) -> Iterator[TabletopSession]:
        known = scenarios()
        if scenario not in known:
            raise KeyError(f"no tabletop scenario {scenario!r}; known: {', '.join(sorted(known))}")
        with open_client(options.gui) as client:
            yield TabletopSession(known[scenario], options, client)


WORLD = TabletopWorld()

__all__ = ["WORLD", "FixedGeometry", "TabletopSession", "TabletopWorld"]
