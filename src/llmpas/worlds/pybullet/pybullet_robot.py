"""The PyBullet world as the executor sees it: a
:class:`~llmpas.execution.robot_protocols.Robot` and a
:class:`~llmpas.execution.robot_protocols.Perception`.

The robot knows its base pose only by odometry (the believed pose drifts from the true one with
seeded noise). Everything it perceives is expressed in its believed frame: a detection is the
camera measurement relative to the true base, placed at the believed base. Arm goals are given in
the believed frame too and executed relative to the true base; so a fresh detection cancels the
odometry error (the Cartesian correction of the approach) while a stale one does not.

Scenario events (someone moves an object) fire inside the skill call that triggers them.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from llmpas.execution.robot_protocols import Observation, SkillResult
from llmpas.worlds.pybullet.camera import CameraConfig, detect, look_at, wrist_image
from llmpas.worlds.pybullet.pybullet_motion import BaseChecker, plan_base
from llmpas.worlds.pybullet.pybullet_values import ArmGoal, BaseConf, BasePath, ObjectPose
from llmpas.worlds.pybullet.scene import TABLE_TOP, Scene
from llmpas.worlds.pybullet.skills import Skills
from llmpas.worlds.pybullet.snapshot import overview

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Event:
    """After the ``count``-th successful call of ``skill``, move ``obj`` onto ``table`` at
    (``dx``, ``dy``) from its centre (the robot is not told)."""

    skill: str
    count: int
    obj: str
    table: str
    dx: float = 0.0
    dy: float = 0.0

    def __post_init__(self) -> None:
        if self.count < 1:
            raise ValueError("event count must be >= 1")


@dataclass
class Frame:
    """A snapshot of the scene at a key moment."""

    label: str
    rgb: np.ndarray = field(repr=False)
    mark: tuple[int, int] = (0, 0)  # (episodes executed before it, timeline events before it)


def _se2(b: tuple[float, float, float]) -> np.ndarray:
    x, y, t = b
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


class PyBulletWorld:
    """Robot skills and perception over one :class:`Scene`."""

    def __init__(
        self,
        scene: Scene,
        rng: np.random.Generator,
        camera: CameraConfig | None = None,
        events: tuple[Event, ...] = (),
        snapshots: bool = True,
    ) -> None:
        self.scene = scene
        self.rng = rng
        self.camera = camera or CameraConfig()
        self.skills = Skills(scene, rng)
        self.checker = BaseChecker.of(scene)
        self.events = list(events)
        self.counts: dict[str, int] = {}
        self.frames: list[Frame] = []
        self.images: list[Frame] = []  # camera views
        self.snapshots = snapshots
        self.clock: Callable[[], tuple[int, int]] = lambda: (0, 0)  # a Frame's mark
        self.log: list[str] = []
        self.snapshot("start")

    # ------------------------------------------------------------------ frames

    def believed(self) -> tuple[float, float, float]:
        return self.skills.believed_base

    def to_true(self, x: float, y: float) -> tuple[float, float]:
        """A point of the believed frame where it really is (relative to the true base)."""
        m = _se2(self.scene.base_pose()) @ np.linalg.inv(_se2(self.believed()))
        v = m @ np.array([x, y, 1.0])
        return float(v[0]), float(v[1])

    def to_believed(self, x: float, y: float) -> tuple[float, float]:
        m = _se2(self.believed()) @ np.linalg.inv(_se2(self.scene.base_pose()))
        v = m @ np.array([x, y, 1.0])
        return float(v[0]), float(v[1])

    def _believed_pose(self, p: ObjectPose) -> ObjectPose:
        x, y = self.to_believed(p.x, p.y)
        return ObjectPose(p.region, round(x, 4), round(y, 4), p.z)

    def _true_pose(self, p: ObjectPose) -> ObjectPose:
        x, y = self.to_true(p.x, p.y)
        return ObjectPose(p.region, x, y, p.z)

    def snapshot(self, label: str) -> None:
        if self.snapshots:
            self.frames.append(Frame(label, overview(self.scene).rgb, self.clock()))

    # ------------------------------------------------------------------ events

    def _done(self, skill: str, result: SkillResult) -> SkillResult:
        self.log.append(f"{skill}: {result.status.value} {result.message}")
        if not result.ok:
            return result
        self.counts[skill] = self.counts.get(skill, 0) + 1
        for e in list(self.events):
            if e.skill == skill and e.count == self.counts[skill]:
                self.scene.place_on(e.obj, e.table, e.dx, e.dy)
                self.scene.settle(60)
                self.events.remove(e)
                self.log.append(f"event: {e.obj} moved to {e.table}")
                self.snapshot(f"event: {e.obj} moved to {e.table}")
        return result

    # ------------------------------------------------------------------ Robot

    def base_conf(self) -> BaseConf:
        x, y, t = self.believed()
        return BaseConf(x, y, t)

    def holding(self) -> str | None:
        return self.scene.held

    def plan_drive(self, target: BaseConf) -> BasePath | None:
        path = plan_base(self.checker, self.believed(), target.pose)
        return None if path is None else BasePath(tuple(path))

    def drive(self, path: BasePath) -> SkillResult:
        """Follow a planned path (believed frame; odometry noise on the way)."""
        self.skills.move_base(path.waypoints)
        self.snapshot(f"drove to {BaseConf(*path.waypoints[-1])}")
        return self._done("move_base", SkillResult.success(f"drove {path.length:.2f} m"))

    def move_base(self, conf: Any) -> SkillResult:
        if not isinstance(conf, BaseConf):
            return SkillResult.failure(f"not a base configuration: {conf!r}", reason="bad_value")
        path = self.plan_drive(conf)
        if path is None:
            return SkillResult.failure(f"no collision-free drive to {conf}", reason="blocked")
        return self.drive(path)

    def move_arm(self, target: Any) -> SkillResult:
        if isinstance(target, str) and target == "home":
            ok = self.skills.home()
            return SkillResult.success("arm folded") if ok else SkillResult.failure("cannot fold")
        if not isinstance(target, ArmGoal):
            return SkillResult.failure(f"not an arm goal: {target!r}", reason="bad_value")
        pose = self._true_pose(target.pose)
        height = goal_height(self.scene, target)
        if target.phase == "pre":
            ignore = () if self.scene.held else tuple(near_graspable(self.scene, pose))
            ok = self.skills.pre_approach(pose, target.grasp.kind, height, ignore=ignore)
            what = "pre-approach"
        else:
            ok = self.skills.approach(pose, target.grasp.kind, height)
            what = "approach"
        if not ok:
            return SkillResult.failure(f"{what} to {target.pose} failed", reason="unreachable")
        return SkillResult.success(f"{what} {target.pose}")

    def wrist_detect(self, obj: str) -> ObjectPose | None:
        """Look with the wrist camera (from a pre-approach) for ``obj``: a fresh pose."""
        img = wrist_image(self.scene, self.camera)
        self.images.append(Frame(f"wrist: {obj}", img.rgb, self.clock()))
        d = detect(self.scene, img, self.rng, self.camera).find(obj)
        return None if d is None else self._believed_pose(d.pose)

    def grasp(self, obj: str, grasp: Any) -> SkillResult:
        if self.scene.held is not None:
            return SkillResult.failure("the hand is full", reason="hand_full")
        if not self.skills.close(obj):
            self.scene.drive_fingers(0.04)
            self.scene.step(60)
            self.skills.lift()
            self.skills.home()
            return self._done("grasp", SkillResult.failure(f"missed {obj}", reason="nothing"))
        self.skills.lift()
        self.skills.home()
        self.snapshot(f"grasped {obj}")
        return self._done("grasp", SkillResult.success(f"holding {obj}"))

    def release(self, obj: str, pose: Any) -> SkillResult:
        if self.scene.held != obj:
            return SkillResult.failure(f"not holding {obj}", reason="not_held")
        self.skills.release()
        self.skills.lift()
        self.skills.home()
        self.snapshot(f"released {obj}")
        return self._done("release", SkillResult.success(f"released {obj}"))

    def open(self, container: str) -> SkillResult:
        return SkillResult.failure(f"{container} cannot be opened", reason="not_openable")

    def close(self, container: str) -> SkillResult:
        return SkillResult.failure(f"{container} cannot be closed", reason="not_openable")

    def process(self, obj: str, appliance: str, how: str) -> SkillResult:
        return SkillResult.failure(f"no {how} here", reason="cannot_process")

    # ------------------------------------------------------------------ Perception

    def look_point(self, region: str | None) -> tuple[float, float, float]:
        if region is not None and region in self.scene.tables:
            cx, cy = self.scene.tables[region].center
            x, y = self.to_true(cx, cy)  # the robot aims where it believes the table is
            return (x, y, TABLE_TOP)
        bx, by, bt = self.scene.base_pose()
        return (bx + 1.0 * math.cos(bt), by + 1.0 * math.sin(bt), TABLE_TOP)

    def look_with_arm(self, target: str | None = None) -> Observation:
        """The search behaviour's arm look: raise the wrist camera above the near edge of the
        table, look at it from there, fold the arm again. Falls back to the mast camera when no
        look pose is reachable."""
        point = np.array(self.look_point(target))
        bx, by, bt = self.scene.base_pose()
        heading = np.array([math.cos(bt), math.sin(bt), 0.0])
        eye = np.array([bx, by, 1.05]) + heading * 0.55
        orn = look_orientation(point - eye)
        q = self.skills.solve(eye, orn)
        if q is None or not self.skills.move_arm(q):
            return self.look(target)
        img = wrist_image(self.scene, self.camera)
        self.images.append(Frame(f"arm look: {target}", img.rgb, self.clock()))
        obs = detect(self.scene, img, self.rng, self.camera)
        self.skills.home()
        return self._believed(obs)

    def _believed(self, obs: Observation) -> Observation:
        dets = tuple(
            type(d)(d.obj, d.region, self._believed_pose(d.pose), d.confidence, d.properties)
            for d in obs.detections
        )
        return Observation(obs.viewed, dets)

    def look(self, target: str | None = None) -> Observation:
        img = look_at(self.scene, self.look_point(target), self.camera)
        self.images.append(Frame(f"look: {target}", img.rgb, self.clock()))
        return self._believed(detect(self.scene, img, self.rng, self.camera))


def look_orientation(axis: np.ndarray) -> tuple[float, float, float, float]:
    """A gripper orientation whose approach (z) axis points along ``axis``."""
    z = np.asarray(axis, dtype=float) / float(np.linalg.norm(axis))
    x = np.cross([0.0, 0.0, 1.0], z)
    if float(np.linalg.norm(x)) < 1e-6:
        x = np.array([1.0, 0.0, 0.0])
    x = x / float(np.linalg.norm(x))
    y = np.cross(z, x)
    return _quaternion(np.column_stack([x, y, z]))


def _quaternion(m: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation matrix."""
    t = float(np.trace(m))
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k]) * 2
        v = [0.0, 0.0, 0.0]
        v[i] = 0.25 * s
        v[j] = (m[j, i] + m[i, j]) / s
        v[k] = (m[k, i] + m[i, k]) / s
        q = (v[0], v[1], v[2], (m[k, j] - m[j, k]) / s)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


__all__ = ["Event", "Frame", "PyBulletWorld", "look_orientation"]


def goal_height(scene: Scene, target: ArmGoal) -> float:
    """The height of what an arm goal handles: the held object, else the target (5 cm unknown)."""
    name = scene.held or target.obj
    known = {o.name for o in scene.config.objects}
    return scene.config.obj(name).height if name in known else 0.05


def near_graspable(scene: Scene, pose: ObjectPose) -> list[str]:
    """Objects within 6 cm of a grasp point (the target itself): not obstacles for the hand."""
    out = []
    for o in scene.config.objects:
        if not o.graspable:
            continue
        at, _ = scene.pose(o.name)
        if math.hypot(at[0] - pose.x, at[1] - pose.y) < 0.06:
            out.append(o.name)
    return out
