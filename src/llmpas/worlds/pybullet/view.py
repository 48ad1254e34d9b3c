"""The PyBullet world's scene for a viewer (:class:`~llmpas.worlds.api.SceneView`): its tables,
its objects where the robot believes them (their ``atpose`` values) and where the simulator has
them, the robot's base and gripper frames and the arm's links."""

from __future__ import annotations

import math

import pybullet as p

from llmpas.execution.context import Belief
from llmpas.worlds.api import Pose3, SceneView, Shape
from llmpas.worlds.pybullet.pybullet_values import ObjectPose
from llmpas.worlds.pybullet.scene import COLOURS, TABLE_TOP, Scene

_TABLE = (0.55, 0.42, 0.3, 1.0)
_SLAB = 0.04  # the drawn thickness of a table top


def _floats(v: object) -> tuple[float, float, float]:
    x, y, z = (float(a) for a in v)  # type: ignore[attr-defined]
    return (x, y, z)


def scene_view(scene: Scene, belief: Belief) -> SceneView:
    """The scene now: tables and believed objects, true objects, the robot's frames."""
    tables = [
        Shape(
            name,
            "place",
            ((r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2, TABLE_TOP - _SLAB / 2),
            (r.x1 - r.x0, r.y1 - r.y0, _SLAB),
            rgba=_TABLE,
        )
        for name, r in scene.tables.items()
    ]
    believed, truth = [], []
    for o in scene.config.objects:
        size = (o.size, o.size, o.height)
        up = o.height / 2 - o.origin_height  # from the pose's z to the centre
        for fact in belief.matching("atpose", o.name):
            at = belief.values.get(fact.args[1])
            if isinstance(at, ObjectPose):
                centre = (at.x, at.y, at.z + up)
                believed.append(Shape(o.name, "object", centre, size, rgba=COLOURS[o.colour]))
        x, y, z = _floats(scene.pose(o.name)[0])
        rgba = (*COLOURS[o.colour][:3], 0.45)
        truth.append(Shape(o.name, "object", (x, y, z + up), size, rgba=rgba))
    x, y, yaw = scene.base_pose()
    base = Pose3(
        "base_link", "world", (x, y, 0.0), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    )
    ee, q = scene.ee_pose()
    quat = tuple(float(a) for a in q)
    norm = math.sqrt(sum(a * a for a in quat)) or 1.0
    gripper = Pose3("gripper", "world", _floats(ee), tuple(a / norm for a in quat))  # type: ignore[arg-type]
    return SceneView(tuple(tables + believed), tuple(truth), (base, gripper, *arm(scene)))


def arm(scene: Scene) -> list[Pose3]:
    """The arm's links (``panda_link1`` ... ``panda_hand``), each in the frame ``world``."""
    c, body = scene.client, scene.panda
    frames = []
    for j in range(p.getNumJoints(body, physicsClientId=c)):
        name = p.getJointInfo(body, j, physicsClientId=c)[12].decode()
        state = p.getLinkState(body, j, computeForwardKinematics=True, physicsClientId=c)
        xyz, q = _floats(state[4]), tuple(float(a) for a in state[5])
        norm = math.sqrt(sum(a * a for a in q)) or 1.0
        frames.append(Pose3(name, "world", xyz, tuple(a / norm for a in q)))  # type: ignore[arg-type]
    return frames


__all__ = ["scene_view"]
