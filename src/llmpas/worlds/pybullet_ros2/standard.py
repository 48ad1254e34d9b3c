"""The simulated robot's side of the standard interfaces: TF, a detector's vision_msgs, Nav2's
error codes and the robot's description (what robot_state_publisher and a perception node
would publish on a real robot). Message classes are imported where a message is built."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pybullet_data

from llmpas.execution.robot_protocols import Observation, SkillResult
from llmpas.worlds.pybullet.camera import MAST, detect, look_at, wrist_image
from llmpas.worlds.pybullet.pybullet_robot import PyBulletWorld
from llmpas.worlds.pybullet.scene import MOUNT_OFFSET, TABLE_TOP
from llmpas.worlds.ros2.nav2 import NO_VALID_PATH, nav2_reason
from llmpas.worlds.ros2.profile import RobotProfile
from llmpas.worlds.ros2.tf import Transform

CAMERA_FRAME = "mast_camera_link"


def nav2_error_code(result: SkillResult) -> int:
    """The code the simulated Nav2 answers a failed drive with."""
    return NO_VALID_PATH if result.data.get("reason") == "blocked" else 9000


def robot_description() -> str:
    """The robot's URDF as robot_state_publisher latches it: ``base_link`` (the Husky, a box),
    fixed to ``panda_link0`` at the mount, and the Panda arm and hand. As on a real robot, the
    visual meshes are ``package://`` references a client cannot read, and collisions are
    primitives (each collision mesh's bounding box, as franka_description's primitive
    collision model does), so that a client plans with the description alone."""
    data = Path(pybullet_data.getDataPath())
    root = ET.fromstring((data / "franka_panda" / "panda.urdf").read_text(encoding="utf-8"))
    for element in root.iter():
        if element.tag not in ("visual", "collision"):
            continue
        geometry = element.find("geometry")
        mesh = None if geometry is None else geometry.find("mesh")
        if geometry is None or mesh is None:
            continue
        filename = mesh.get("filename", "").removeprefix("package://")
        if element.tag == "visual":
            mesh.set("filename", f"package://franka_panda/{filename}")
            continue
        lo, hi = _obj_bounds(data / "franka_panda" / filename)
        origin = element.find("origin")
        rpy = (
            [0.0, 0.0, 0.0]
            if origin is None
            else [float(v) for v in origin.get("rpy", "0 0 0").split()]
        )
        xyz = (
            [0.0, 0.0, 0.0]
            if origin is None
            else [float(v) for v in origin.get("xyz", "0 0 0").split()]
        )
        centre = (lo + hi) / 2
        turn = rpy[2]  # the finger's collision is turned about z only
        c, s = math.cos(turn), math.sin(turn)
        at = [xyz[0] + c * centre[0] - s * centre[1], xyz[1] + s * centre[0] + c * centre[1],
              xyz[2] + centre[2]]  # fmt: skip
        if origin is None:
            origin = ET.SubElement(element, "origin")
        origin.set("xyz", " ".join(f"{v:.5f}" for v in at))
        origin.set("rpy", f"0 0 {turn:.6f}")
        geometry.remove(mesh)
        ET.SubElement(geometry, "box", size=" ".join(f"{v:.5f}" for v in hi - lo))
    half, centre = _base_box()
    base = ET.Element("link", name="base_link")
    collision = ET.SubElement(base, "collision")
    ET.SubElement(collision, "origin", xyz=" ".join(f"{v:.4f}" for v in centre), rpy="0 0 0")
    ET.SubElement(ET.SubElement(collision, "geometry"), "box",
                  size=" ".join(f"{2 * v:.4f}" for v in half))  # fmt: skip
    mount = ET.Element("joint", name="base_to_panda", type="fixed")
    ET.SubElement(mount, "parent", link="base_link")
    ET.SubElement(mount, "child", link="panda_link0")
    ET.SubElement(mount, "origin", xyz=" ".join(f"{v:g}" for v in MOUNT_OFFSET), rpy="0 0 0")
    root.insert(0, mount)
    root.insert(0, base)
    root.set("name", "husky_panda")
    return ET.tostring(root, encoding="unicode")


def _obj_bounds(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box of a Wavefront OBJ mesh's vertices."""
    points = [
        [float(v) for v in line.split()[1:4]]
        for line in path.read_text(encoding="utf-8", errors="replace").splitlines()
        if line.startswith("v ")
    ]
    array = np.array(points)
    return array.min(axis=0), array.max(axis=0)


def _base_box() -> tuple[list[float], list[float]]:
    """The Husky's bounding box in its own frame (half extents, centre), from pybullet_data's
    model (the simulator's, never sent as a file)."""
    import pybullet as p

    from llmpas.worlds.pybullet.scene import quiet_fds

    with quiet_fds():
        cid = p.connect(p.DIRECT)
    try:
        path = str(Path(pybullet_data.getDataPath()) / "husky" / "husky.urdf")
        with quiet_fds():
            body = p.loadURDF(path, [0, 0, 0], useFixedBase=True, physicsClientId=cid)
        boxes = [p.getAABB(body, link, physicsClientId=cid)
                 for link in range(-1, p.getNumJoints(body, physicsClientId=cid))]  # fmt: skip
    finally:
        p.disconnect(physicsClientId=cid)
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    return [float(v) for v in (hi - lo) / 2], [float(v) for v in (hi + lo) / 2]


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
