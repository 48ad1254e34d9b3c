"""Values of the PyBullet parts as ROS 2 messages and back, and the simulator's state as JSON
(the planning scene a client mirrors). Only plain data here: message classes are passed in or
imported where a message is built, never at module import."""

from __future__ import annotations

import json
import math
from typing import Any

import pybullet as p

from llmpas.execution.robot_protocols import Detection, Observation
from llmpas.worlds.pybullet.pybullet_values import ArmGoal, BaseConf, Grasp, ObjectPose
from llmpas.worlds.pybullet.scene import Scene

FRAME = "map"
PANDA_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def quaternion_yaw(z: float, w: float) -> float:
    return 2.0 * math.atan2(z, w)


def pose_stamped(x: float, y: float, z: float, yaw: float = 0.0) -> Any:
    from geometry_msgs.msg import PoseStamped

    msg = PoseStamped()
    msg.header.frame_id = FRAME
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = float(x), float(y), float(z)
    q = yaw_quaternion(yaw)
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = q
    return msg


def base_of(msg: Any) -> BaseConf:
    pos, o = msg.pose.position, msg.pose.orientation
    return BaseConf(float(pos.x), float(pos.y), quaternion_yaw(float(o.z), float(o.w)))


def arm_goal_json(goal: ArmGoal) -> str:
    pose = goal.pose
    return json.dumps(
        {
            "pose": [pose.region, pose.x, pose.y, pose.z],
            "grasp": goal.grasp.kind,
            "phase": goal.phase,
            "obj": goal.obj,
        }
    )


def object_pose(raw: list[Any]) -> ObjectPose:
    region, x, y, z = raw
    return ObjectPose(str(region), float(x), float(y), float(z))


def arm_goal(text: str) -> ArmGoal:
    raw = json.loads(text)
    return ArmGoal(object_pose(raw["pose"]), Grasp(raw["grasp"]), raw["phase"], raw["obj"])


def detections_msg(obs: Observation, camera: str) -> Any:
    from llmpas_interfaces.msg import Detection as DetectionMsg
    from llmpas_interfaces.msg import Detections

    msg = Detections()
    msg.header.frame_id = FRAME
    msg.camera = camera
    msg.viewed = list(obs.viewed)
    for d in obs.detections:
        m = DetectionMsg()
        m.object, m.region, m.confidence = d.obj, d.region, float(d.confidence)
        m.properties = sorted(d.properties)
        pose = d.pose
        if isinstance(pose, ObjectPose):
            m.pose = pose_stamped(pose.x, pose.y, pose.z)
        msg.detections.append(m)
    return msg


def observation(msg: Any) -> Observation:
    dets = tuple(
        Detection(
            d.object,
            d.region,
            ObjectPose(
                d.region,
                float(d.pose.pose.position.x),
                float(d.pose.pose.position.y),
                float(d.pose.pose.position.z),
            ),
            min(1.0, max(0.0, float(d.confidence))),
            frozenset(d.properties),
        )
        for d in msg.detections
    )
    return Observation(tuple(msg.viewed), dets)


# ---------------------------------------------------------------------- the planning scene


def scene_state(scene: Scene, believed: tuple[float, float, float]) -> str:
    """Every body's pose, velocity and joint positions, what the hand holds and the believed
    base pose, as JSON (floats round-trip exactly)."""
    c = scene.client
    bodies = []
    for i in range(p.getNumBodies(physicsClientId=c)):
        b = p.getBodyUniqueId(i, physicsClientId=c)
        pos, orn = p.getBasePositionAndOrientation(b, physicsClientId=c)
        lin, ang = p.getBaseVelocity(b, physicsClientId=c)
        n = p.getNumJoints(b, physicsClientId=c)
        joints = (
            [list(s[:2]) for s in p.getJointStates(b, range(n), physicsClientId=c)] if n else []
        )
        bodies.append([b, list(pos), list(orn), list(lin), list(ang), joints])
    grip = getattr(scene, "_grip", None)
    return json.dumps(
        {
            "believed": list(believed),
            "held": scene.held,
            "grip": None if grip is None else [list(grip[0]), list(grip[1])],
            "bodies": bodies,
        }
    )


def apply_state(scene: Scene, text: str) -> tuple[float, float, float]:
    """Put ``scene`` (a mirror built from the same configuration) in the state of
    :func:`scene_state`; returns the believed base pose."""
    c = scene.client
    state = json.loads(text)
    for b, pos, orn, lin, ang, joints in state["bodies"]:
        p.resetBasePositionAndOrientation(b, pos, orn, physicsClientId=c)
        p.resetBaseVelocity(b, lin, ang, physicsClientId=c)
        for j, (q, v) in enumerate(joints):
            p.resetJointState(b, j, q, v, physicsClientId=c)
    scene.held = state["held"]
    grip = state["grip"]
    scene._grip = None if grip is None else (list(grip[0]), list(grip[1]))
    x, y, t = state["believed"]
    return (float(x), float(y), float(t))


__all__ = [
    "FRAME",
    "PANDA_JOINTS",
    "apply_state",
    "arm_goal",
    "arm_goal_json",
    "base_of",
    "detections_msg",
    "object_pose",
    "observation",
    "pose_stamped",
    "scene_state",
]
