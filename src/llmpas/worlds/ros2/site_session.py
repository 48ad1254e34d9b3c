"""A standard ROS 2 robot at a site (``--world ros2 --site FILE``): the session plans from what
the robot gives and what the site says, nothing else.

The planning scene (:class:`~llmpas.worlds.ros2.site_scene.SiteScene`) is built from the site's
places, furniture and told objects and the robot's ``robot_description``; the base comes from
TF, the arm from ``joint_states``, objects from the detections. The initial belief is what the
site tells (an object told of without a place: its whereabouts unknown; an object neither told of
nor seen is in no scene). No scenario is read and no simulator started here: the verdict is
what the robot perceived (the planning scene's state), labelled so (``verdict_basis``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import ExecutorConfig
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.planning.result import Plan
from llmpas.worlds.api import RunOptions, holds
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.kitchen.kitchen_session import PLANNER, KitchenSearch, KitchenSession
from llmpas.worlds.pybullet.facts import true_facts
from llmpas.worlds.pybullet.pybullet_decomposition import build_specs, table_of
from llmpas.worlds.pybullet.pybullet_problem import (
    believe_base,
    initial_belief,
    make_problem,
    static_facts,
)
from llmpas.worlds.pybullet.pybullet_reasoning import environment, prompt_tables, vocabulary
from llmpas.worlds.pybullet.pybullet_streams import Geometry
from llmpas.worlds.pybullet.pybullet_values import BaseConf, ObjectPose
from llmpas.worlds.pybullet.scene import TABLE_TOP, Scene, SceneConfig
from llmpas.worlds.ros2.client import RobotUnavailableError
from llmpas.worlds.ros2.recording import BAG, Recording
from llmpas.worlds.ros2.robot_model import DescriptionError, arm_model
from llmpas.worlds.ros2.rosbag import McapRecorder
from llmpas.worlds.ros2.site import Site, SiteError, Task
from llmpas.worlds.ros2.site_scene import SiteScene, object_config
from llmpas.worlds.ros2.standard_robot import StandardRobot

log = logging.getLogger(__name__)

TOPICS = {  # recorded topics: the profile's topic key -> (package, message)
    "odom": ("nav_msgs.msg", "Odometry"),
    "joint_states": ("sensor_msgs.msg", "JointState"),
    "detections": ("vision_msgs.msg", "Detection3DArray"),
    "wrist_detections": ("vision_msgs.msg", "Detection3DArray"),
    "tf": ("tf2_msgs.msg", "TFMessage"),
    "tf_static": ("tf2_msgs.msg", "TFMessage"),
}


class SiteGeometry(Geometry):
    """The planner's geometry at a site: poses sampled along a place's sides, then the base
    poses the site gives to look at the place and to reach it (those free of the furniture; a
    reach pose only where the arm reaches the object from it), so that a place whose sides
    the sampler cannot use is still looked at and reached. (Tried first, the site's poses
    changed what the robot saw on the shipped house site, and the replayed model's recorded
    answers no longer covered the run.)"""

    def __init__(self, scene: Scene, rng: np.random.Generator, site: Site) -> None:
        super().__init__(scene, rng)
        self.site = site

    def _given(self, place: str, reach: bool) -> list[BaseConf]:
        try:
            found = self.site.place(place)
        except KeyError:
            return []
        poses = found.reach if reach else found.views
        return [BaseConf(b.x, b.y, b.yaw) for b in poses]

    def views(self, table: str, near: tuple[float, float] | None) -> Iterator[BaseConf]:
        yield from super().views(table, near)
        for q in self._given(table, reach=False):
            if self.checker.free(q.pose):
                yield q

    def kin(self, obj: str, pose: ObjectPose, grasp: Any) -> Iterator[BaseConf]:
        yield from super().kin(obj, pose, grasp)
        table = self.table_of(pose)
        if table is not None:
            height = self.scene.config.obj(obj).height
            for q in self._given(table, reach=True):
                if self.reaches(q, pose, grasp, height):
                    yield q


class LiveConfig:
    """The planning scene's configuration as it is when read: the subtrees' checks see an
    object first seen after they were built (a lid the robot finds lying over the bowl it
    is about to place into)."""

    def __init__(self, scene: Scene) -> None:
        self._scene = scene

    def __getattr__(self, name: str) -> Any:
        return getattr(self._scene.config, name)


def site_belief(scene: Scene, site: Site, base: BaseConf) -> Belief:
    """What the site tells: each told object where it was told (a point on its place, else the
    place's middle); an object told without a place, whereabouts unknown."""
    poses: dict[str, ObjectPose | None] = {}
    for o in scene.config.objects:
        told = next(t for t in site.objects if t.name == o.name)
        if not told.place:
            continue
        cx, cy = scene.tables[o.table].center
        poses[o.name] = ObjectPose(o.table, round(cx + o.dx, 3), round(cy + o.dy, 3),
                                   TABLE_TOP + o.origin_height)  # fmt: skip
    return initial_belief(scene.config, poses, base)


def site_search(scene: Scene, belief: Belief) -> KitchenSearch:
    """Searching at a site: drive to a place and look at it."""
    config = scene.config

    def looked_at(report: AnomalyReport) -> tuple[str, ...]:
        c = report.constraint
        if not isinstance(c, Atom) or len(c.args) < 2:
            return ()
        return (table_of(config, belief, c.args[1]),)

    places = tuple(t.name for t in config.tables)
    known = frozenset(o.name for o in config.objects)
    return KitchenSearch(belief, places, known, ObjectPose, looked_at)


class SiteSession(Recording, KitchenSession):
    """One task at a site, driving a standard robot over ROS 2."""

    verdict_basis = "perceived"  # the verdict is judged on what the robot perceived

    def __init__(self, task: Task, site: Site, plugin: Any, options: RunOptions, client: int,
                 context: Any, folder: Path, profile: Any) -> None:  # fmt: skip
        self.scenario = task
        self.site = site
        self.seed = 0 if options.seed is None else options.seed
        self.planner = options.planner or PLANNER
        self.executor = options.executor or ExecutorConfig()
        self.exploration = plugin.exploration
        self.timings: dict[str, float] = {}
        self.folder = folder
        self.profile = profile
        t0 = time.perf_counter()
        self.bag = McapRecorder(folder / BAG)

        def build(description: str, base: tuple[float, float, float]) -> Scene:
            try:
                arm = arm_model(description, profile.arm.joints[0], profile.frames.base)
                return SiteScene(client, site, arm, base)
            except DescriptionError as e:
                raise RobotUnavailableError(f"robot_description: {e}") from None

        self.robot = StandardRobot(context, None, profile, np.random.default_rng([self.seed, 0]),
                                   plugin.timeouts, self._record_goal, build)  # fmt: skip
        self.world = self.robot
        self.saved = False
        try:
            self.subscriptions = [self._subscribe(t, *m) for t, m in TOPICS.items()]
            self.robot.wait_for_servers()
        except BaseException:
            self.bag.close()
            self.robot.shutdown()
            raise
        self.scene = self.robot.scene
        self.timings["connect"] = time.perf_counter() - t0
        belief = site_belief(self.scene, site, self.robot.base_conf())
        self.geometry = SiteGeometry(self.scene, np.random.default_rng([self.seed, 1]), site)
        self.context = Context(self.robot, self.robot, belief,
                               np.random.default_rng([self.seed, 2]))  # fmt: skip
        self.domain = load_domain()
        self.vocabulary = vocabulary(self.scene.config)
        self.prompts = prompt_tables(self.scene.config)
        self.search = site_search(self.scene, belief)
        self.rounds = 0
        self.episodes = 0
        self.anomalies = 0
        self._recorder: Any = self.context.recorder
        self._seen = 0
        self.robot.clock = lambda: (self.rounds, len(self.context.recorder.events))
        self.ignored: set[str] = set()  # class ids seen that name nothing the planner can use
        self.discovered: list[str] = []
        self.robot.discover = self.discover

    def discover(
        self, name: str, at: tuple[float, float, float], size: tuple[float, float, float]
    ) -> bool:
        """An object seen that the site did not tell of: into the planning scene, the belief's
        static facts and the reasoner's vocabulary, when its class id names one of the site's
        classes and it lies on a place (one object per class id); a class id the site names no
        class for, or one the planner cannot plan for, is ignored from then on (the log says
        why once)."""
        if name in self.ignored:
            return False
        why = ""
        try:
            cls = self.site.cls(name)
        except KeyError:
            why = "the site names no such class"
        if why:
            self.ignored.add(name)
            log.info("a detected %r ignored: %s", name, why)
            return False
        place = self.site.place_of(at[0], at[1])
        if place is None:  # not yet: it may be seen on a place later
            log.debug("a detected %r on none of the site's places", name)
            return False
        old = self.scene.config
        try:
            o = object_config(self.site, name, cls, place, (at[0], at[1]), "", f"classes.{name}")
        except SiteError as e:
            self.ignored.add(name)
            log.info("a detected %r ignored: %s", name, e)
            return False
        self.scene.add_object(o, at)
        self.belief.facts |= static_facts(self.scene.config) - static_facts(old)
        self.vocabulary = vocabulary(self.scene.config)
        self.prompts = prompt_tables(self.scene.config)
        self.search = site_search(self.scene, self.belief)
        self.discovered.append(name)
        log.info("seen %s (size %s), which the site did not tell of, on %s", name, size, place)
        return True

    # ------------------------------------------------------------------ the loop's parts

    def sync_base(self) -> None:
        """Believe the base is where TF says (after a failed subtree drove around)."""
        believe_base(self.belief, self.robot.base_conf())

    def problem(self, goal: Formula | str, index: int) -> Problem:
        self.sync_base()
        return make_problem(self.geometry, self.belief, goal, here=self.robot.base_conf())

    def decompose(self, problem: Problem, plan: Plan) -> Sequence[SubtreeSpec]:
        self.rounds, self.episodes = self.episodes, self.episodes + 1
        live = cast(SceneConfig, LiveConfig(self.scene))  # objects seen mid-round included
        return build_specs(live, problem, plan, self.exploration)

    def environment(self) -> str:
        return environment(self.scene.config, self.belief)

    def perceived_facts(self) -> frozenset[Atom]:
        """The planning scene's state as facts: what the robot perceived (detections, the
        gripper's results), not the world's truth."""
        return true_facts(self.scene)

    def achieved(self) -> bool:
        """The task judged on what the robot perceived."""
        return holds(self.task, self.perceived_facts())

    def about(self) -> dict[str, Any]:
        return {
            "verdict": "perceived",
            "site": {"name": self.site.name, "file": self.site.source, "task": self.name},
            "discovered": list(self.discovered),  # seen, not told of
        }


__all__ = ["SiteGeometry", "SiteSession", "site_belief", "site_search"]
