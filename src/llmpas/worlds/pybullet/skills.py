"""The robot's skills with real effects in the PyBullet scene.

Arm motions are kinematic along planned (collision-checked) joint paths, with the joint motors
holding every way point and the physics stepping between them; a held object follows the gripper
(a fixed constraint, and its pose is reset to the grasp after each kinematic move). Base motion
follows a planned SE(2) path and accumulates seeded odometry noise: where the Husky ends up differs
from where it believes it is.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from llmpas.worlds.pybullet.kinematics import (
    Collision,
    Conf,
    IKConfig,
    forward_grasp_orientation,
    preserved,
    solve_ik,
    top_grasp_orientation,
)
from llmpas.worlds.pybullet.pybullet_motion import MotionConfig, Pose2, plan_arm
from llmpas.worlds.pybullet.pybullet_values import ObjectPose, Vector
from llmpas.worlds.pybullet.scene import FINGER_OPEN, HOME_CONF, Scene

log = logging.getLogger(__name__)

GRASPS = ("top", "forward")


@dataclass(frozen=True)
class SkillConfig:
    pre_distance: float = 0.12  # pre-approach: this far from the grasp, against the approach
    lift: float = 0.15  # after a grasp / release: this far up
    cartesian_step: float = 0.02  # metres between IK way points of a straight gripper move
    steps_per_waypoint: int = 2  # physics steps while moving through one way point
    close_steps: int = 90
    release_steps: int = 120
    grip_force: float = 60.0
    odometry_noise: float = 0.01  # metres per metre driven (standard deviation)
    heading_noise: float = 0.01  # radians per metre driven
    max_joint_jump: float = 0.35  # radians between consecutive Cartesian way points

    def __post_init__(self) -> None:
        for name in ("pre_distance", "lift", "cartesian_step", "max_joint_jump"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive")
        if min(self.steps_per_waypoint, self.close_steps, self.release_steps) < 1:
            raise ValueError("step counts must be >= 1")
        if self.odometry_noise < 0 or self.heading_noise < 0 or self.grip_force <= 0:
            raise ValueError("noise must be >= 0 and grip_force positive")


def grasp_orientation(kind: str, heading: float) -> tuple[float, float, float, float]:
    if kind == "top":
        return top_grasp_orientation(heading)
    if kind == "forward":
        return forward_grasp_orientation(heading)
    raise ValueError(f"grasp kind must be one of {GRASPS}, got {kind!r}")


def approach_axis(kind: str, heading: float) -> np.ndarray:
    """The direction the gripper moves in to grasp."""
    if kind == "top":
        return np.array([0.0, 0.0, -1.0])
    return np.array([math.cos(heading), math.sin(heading), 0.0])


class Skills:
    """Pick-and-place skills of the Husky + Panda in one scene."""

    def __init__(
        self,
        scene: Scene,
        rng: np.random.Generator,
        config: SkillConfig | None = None,
        planner: MotionConfig | None = None,
        ik: IKConfig | None = None,
    ) -> None:
        self.scene = scene
        self.rng = rng
        self.config = config or SkillConfig()
        self.planner = planner or MotionConfig()
        self.ik = ik or IKConfig()
        self.believed_base: Pose2 = scene.base_pose()

    # ------------------------------------------------------------------ helpers

    def collision(self, ignore: Sequence[str] = ()) -> Collision:
        s = self.scene
        names = [n for n in s.bodies if n not in ignore and n != s.held]
        return Collision(s, names, attached=s.held)

    def heading_to(self, x: float, y: float) -> float:
        bx, by, _ = self.scene.base_pose()
        return math.atan2(y - by, x - bx)

    def follow(self, path: Sequence[Sequence[float]]) -> None:
        s = self.scene
        for q in path:
            s.set_arm(q)
            s.carry()
            s.step(self.config.steps_per_waypoint)
        s.carry()

    def move_arm(self, goal: Sequence[float], ignore: Sequence[str] = ()) -> bool:
        """Plan (RRT-Connect) and follow a collision-free path to ``goal``."""
        path = plan_arm(
            self.scene, self.scene.arm_conf(), goal, self.collision(ignore), self.planner
        )
        if path is None:
            return False
        self.follow(path)
        return True

    def home(self) -> bool:
        return self.move_arm(HOME_CONF)

    def solve(self, pos: Vector, orn: Vector, ignore: Sequence[str] = ()) -> Conf | None:
        return solve_ik(self.scene, pos, orn, self.rng, self.ik, valid=self.collision(ignore))

    def cartesian(self, target: Vector, orn: Vector) -> bool:
        """Move the gripper in a straight line to ``target`` (IK way points seeded by the previous
        one; fails, without moving, if any way point is unreachable or jumps)."""
        s, cfg = self.scene, self.config
        start, _ = s.ee_pose()
        goal = np.asarray(target, dtype=float)
        n = max(1, math.ceil(float(np.linalg.norm(goal - start)) / cfg.cartesian_step))
        path: list[Conf] = []
        q = s.arm_conf()
        strict = IKConfig(attempts=1, refinements=self.ik.refinements, pos_tol=0.004)
        with preserved(s):
            for k in range(1, n + 1):
                point = start + (goal - start) * k / n
                nxt = solve_ik(s, point, orn, self.rng, strict, seed=q)
                if nxt is None or max(abs(a - b) for a, b in zip(nxt, q, strict=True)) > (
                    cfg.max_joint_jump
                ):
                    return False
                path.append(nxt)
                q = nxt
        self.follow(path)
        return True

    # ------------------------------------------------------------------ base

    def move_base(self, path: Sequence[Pose2]) -> Pose2:
        """Drive along ``path``; odometry noise makes the true pose drift from the plan. Returns
        the believed (planned) end pose."""
        s, cfg = self.scene, self.config
        err = np.zeros(3)
        for a, b in itertools.pairwise(path):
            d = math.hypot(b[0] - a[0], b[1] - a[1]) + 0.1 * abs(b[2] - a[2])
            err += (
                self.rng.normal(0.0, 1.0, 3)
                * np.array([cfg.odometry_noise, cfg.odometry_noise, cfg.heading_noise])
                * d
            )
            s.set_base(b[0] + err[0], b[1] + err[1], b[2] + err[2])
            s.carry()
            s.step(1)
        end = tuple(path[-1])
        self.believed_base = (end[0], end[1], end[2])
        return self.believed_base

    # ------------------------------------------------------------------ manipulation

    def grasp_frame(
        self, pose: ObjectPose, kind: str, height: float
    ) -> tuple[np.ndarray, tuple[float, float, float, float], np.ndarray]:
        """Grasp point, gripper orientation and approach axis for an object of ``height``."""
        heading = self.heading_to(pose.x, pose.y)
        if kind == "top":
            point = np.array([pose.x, pose.y, pose.z + height / 2 - 0.015])
            yaw = heading
        else:
            point = np.array([pose.x, pose.y, pose.z + 0.005])
            yaw = heading
        return point, grasp_orientation(kind, yaw), approach_axis(kind, heading)

    def pre_approach(
        self, pose: ObjectPose, kind: str, height: float, ignore: Sequence[str] = ()
    ) -> bool:
        """Bring the gripper ``pre_distance`` before the grasp (collision-free RRT path)."""
        point, orn, axis = self.grasp_frame(pose, kind, height)
        pre = point - axis * self.config.pre_distance
        q = self.solve(pre, orn, ignore)
        if q is None:
            return False
        return self.move_arm(q, ignore)

    def approach(self, pose: ObjectPose, kind: str, height: float) -> bool:
        """Move straight onto the grasp point of (a possibly corrected) ``pose``."""
        point, orn, _ = self.grasp_frame(pose, kind, height)
        return self.cartesian(point, orn)

    def close(self, name: str) -> bool:
        """Close the fingers; hold ``name`` if it is between them (the fingers stop on it)."""
        s = self.scene
        s.drive_fingers(0.0, self.config.grip_force)
        s.step(self.config.close_steps)
        width = s.finger_width()
        ee, _ = s.ee_pose()
        obj, _ = s.pose(name)
        between = width > 0.01 and float(np.linalg.norm(obj - ee)) < 0.05
        if not between:
            log.debug("grasp of %s missed (width %.3f)", name, width)
            return False
        s.attach(name)
        return True

    def lift(self) -> bool:
        ee, orn = self.scene.ee_pose()
        return self.cartesian(ee + np.array([0.0, 0.0, self.config.lift]), orn)

    def release(self) -> None:
        s = self.scene
        s.detach()
        s.drive_fingers(FINGER_OPEN)
        s.step(self.config.release_steps)

    def pick(self, name: str, pose: ObjectPose, kind: str = "top", height: float = 0.05) -> bool:
        """The whole pick: pre-approach, approach, close, lift, home."""
        return (
            self.pre_approach(pose, kind, height, ignore=(name,))
            and self.approach(pose, kind, height)
            and self.close(name)
            and self.lift()
            and self.home()
        )

    def place(self, pose: ObjectPose, height: float = 0.05, drop: float = 0.03) -> bool:
        """Put the held object down with its centre above ``pose`` (a table spot or a bowl's
        centre), ``drop`` above the resting height, release, lift and fold the arm."""
        s = self.scene
        if s.held is None:
            return False
        target = ObjectPose(pose.region, pose.x, pose.y, pose.z + drop)
        ok = self.pre_approach(target, "top", height) and self.approach(target, "top", height)
        if not ok:
            return False
        self.release()
        return self.lift() and self.home()
