"""The simulated robot's side of the standard interfaces: TF, a detector's vision_msgs, Nav2's
error codes and the robot's description (what robot_state_publisher and a perception node
would publish on a real robot). Message classes are imported where a message is built."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pybullet_data

from llmpas.execution.world import Observation, SkillResult
from llmpas.worlds.pybullet.camera import MAST, detect, look_at, wrist_image
from llmpas.worlds.pybullet.scene import TABLE_TOP
from llmpas.worlds.pybullet.world import PyBulletWorld
from llmpas.worlds.ros2.profile import RobotProfile
from llmpas.worlds.ros2.tf import Transform

CAMERA_FRAME = "mast_camera_link"

# Nav2 (Jazzy): the navigator's result carries the failing task server's code:
# nav2_msgs/action/ComputePathToPose 200-208, FollowPath 100-106, the navigator's own 9000s.
PLANNER_CODES = {
    200: "unknown",
    201: "invalid_planner",
    202: "tf",
    203: "start_outside_map",
    204: "blocked",  # GOAL_OUTSIDE_MAP
    205: "start_occupied",
    206: "blocked",  # GOAL_OCCUPIED
    207: "timeout",
    208: "blocked",  # NO_VALID_PATH
}
CONTROLLER_CODES = {
    100: "unknown",
    101: "invalid_controller",
    102: "tf",
    103: "invalid_path",
    104: "stuck",  # PATIENCE_EXCEEDED
    105: "stuck",  # FAILED_TO_MAKE_PROGRESS
    106: "stuck",  # NO_VALID_CONTROL
}
NO_VALID_PATH = 208


def nav2_reason(code: int) -> str:
    """The failure's reason for a NavigateToPose ``error_code`` (``aborted`` when unknown)."""
    if code in PLANNER_CODES:
        return PLANNER_CODES[code]
    if code in CONTROLLER_CODES:
        return CONTROLLER_CODES[code]
    if code == 9003:
        return "timeout"
    if code == 9002:
        return "tf"
    return "aborted"


def nav2_error_code(result: SkillResult) -> int:
    """The code the simulated Nav2 answers a failed drive with."""
    return NO_VALID_PATH if result.data.get("reason") == "blocked" else 9000


def robot_description() -> str:
    """The robot's URDF as robot_state_publisher latches it (the Panda arm llmpas plans for)."""
    path = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
    return path.read_text(encoding="utf-8")


def _transform_msg(parent: str, child: str, t: Transform, stamp: Any) -> Any:
    from geometry_msgs.msg import TransformStamped

    m = TransformStamped()
    m.header.stamp, m.header.frame_id, m.child_frame_id = stamp, parent, child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = t.translation
    r = m.transform.rotation
    r.x, r.y, r.z, r.w = t.rotation
    return m


def static_transforms(profile: RobotProfile, stamp: Any) -> Any:
    """``/tf_static``: the mast camera on the base."""
    from tf2_msgs.msg import TFMessage

    camera = Transform((MAST[0], MAST[1], MAST[2]))
    return TFMessage(transforms=[_transform_msg(profile.frames.base, CAMERA_FRAME, camera, stamp)])


def base_transforms(profile: RobotProfile, believed: tuple[float, float, float], stamp: Any) -> Any:
    """``/tf``: ``map -> odom`` (identity: the odometry is the localisation) and ``odom ->
    base_link`` (where the robot believes it is)."""
    from tf2_msgs.msg import TFMessage

    f = profile.frames
    return TFMessage(
        transforms=[
            _transform_msg(f.map, f.odom, Transform(), stamp),
            _transform_msg(f.odom, f.base, Transform.planar(*believed), stamp),
        ]
    )


def _aim(world: PyBulletWorld) -> tuple[float, float, float]:
    """The mast camera's pan-tilt: the nearest table in front of the robot, else 1 m ahead."""
    bx, by, bt = world.scene.base_pose()
    best: tuple[float, tuple[float, float, float]] | None = None
    for rect in world.scene.tables.values():
        cx, cy = rect.center
        d = math.hypot(cx - bx, cy - by)
        off = abs(math.remainder(math.atan2(cy - by, cx - bx) - bt, math.tau))
        if off < math.radians(60) and d < 4.0 and (best is None or d < best[0]):
            best = (d, (cx, cy, TABLE_TOP))
    return best[1] if best else world.look_point(None)


def mast_detections(world: PyBulletWorld, rng: np.random.Generator) -> Observation:
    """What the mast camera sees now (true poses in ``map``)."""
    return detect(world.scene, look_at(world.scene, _aim(world), world.camera), rng, world.camera)


def wrist_detections(world: PyBulletWorld, rng: np.random.Generator) -> Observation:
    return detect(world.scene, wrist_image(world.scene, world.camera), rng, world.camera)


def detection_array(obs: Observation, frame: str, stamp: Any, world: PyBulletWorld) -> Any:
    """A detector's ``vision_msgs/Detection3DArray`` in ``frame`` (the mast camera's or the
    base's): one detection per object seen (class_id its name, score its confidence) and one
    per table in view (class_id the table)."""
    from vision_msgs.msg import Detection3D, Detection3DArray, ObjectHypothesisWithPose

    scene = world.scene
    base = Transform.planar(*scene.base_pose())  # the true base: what the camera measures from
    to_frame = (base * Transform((MAST[0], MAST[1], MAST[2]))) if frame == CAMERA_FRAME else base
    inverse = to_frame.inverse()
    seen: list[tuple[str, tuple[float, float, float], float, tuple[float, float, float]]] = []
    for d in obs.detections:
        pose = d.pose
        size = scene.config.obj(d.obj)
        seen.append(
            (d.obj, (pose.x, pose.y, pose.z), d.confidence, (size.size, size.size, size.height))
        )
    for t in obs.viewed:
        if t in scene.tables:
            cx, cy = scene.tables[t].center
            rect = scene.tables[t]
            seen.append((t, (cx, cy, TABLE_TOP), 1.0, (rect.x1 - rect.x0, rect.y1 - rect.y0, 0.0)))
    msg = Detection3DArray()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    for name, at, score, extent in seen:
        x, y, z = inverse.apply(at)
        d3 = Detection3D()
        d3.header = msg.header
        d3.id = name
        h = ObjectHypothesisWithPose()
        h.hypothesis.class_id, h.hypothesis.score = name, float(score)
        h.pose.pose.position.x, h.pose.pose.position.y, h.pose.pose.position.z = x, y, z
        h.pose.pose.orientation.w = 1.0
        d3.results = [h]
        d3.bbox.center = h.pose.pose
        d3.bbox.size.x, d3.bbox.size.y, d3.bbox.size.z = (float(v) for v in extent)
        msg.detections.append(d3)
    return msg


__all__ = [
    "CAMERA_FRAME",
    "base_transforms",
    "detection_array",
    "mast_detections",
    "nav2_error_code",
    "nav2_reason",
    "robot_description",
    "static_transforms",
    "wrist_detections",
]
