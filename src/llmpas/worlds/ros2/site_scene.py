"""The planning scene of a standard robot at a site: the site's places, furniture and told
objects, the robot's arm and base from its ``robot_description`` (never a model file of llmpas or
pybullet_data), in a PyBullet client used as a collision checker.

The planner (the PyBullet world's streams, skills and decomposition) works on a
:class:`~llmpas.worlds.pybullet.scene.SceneConfig`; :func:`scene_config` writes the site as one
and says, naming the site's key, what that planner cannot plan for: a surface at another height
than its skills' (0.625 m), a region that is not an axis-aligned rectangle, a container place,
an object class of another shape than its cube, bowl and lid.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pybullet as p

from llmpas.worlds.pybullet.scene import (
    ARM_JOINTS,
    BOWL_HEIGHT,
    COLOURS,
    EE_LINK,
    FINGER_JOINTS,
    FINGER_OPEN,
    HOME_CONF,
    TABLE_TOP,
    ObjectConfig,
    Rect,
    Scene,
    SceneConfig,
    TableConfig,
    quiet_fds,
)
from llmpas.worlds.ros2.robot_model import ArmModel, DescriptionError
from llmpas.worlds.ros2.site import ObjectClass, Site, SiteError

SHAPE_KIND = {"box": "cube", "container": "bowl", "lid": "lid"}
PARKED = (0.0, 0.0, -20.0)  # a told object of unknown whereabouts, until it is seen
FINGERS = ("panda_finger_joint1", "panda_finger_joint2")


def _where(site: Site, key: str) -> str:
    return f"{site.source or site.name}: {key}"


def object_config(site: Site, name: str, cls: ObjectClass, place: str,
                  at: tuple[float, float], colour: str, key: str) -> ObjectConfig:  # fmt: skip
    """An object of class ``cls`` at ``at`` on ``place`` as the planner's configuration
    (:class:`SiteError` naming ``key`` or the class when the planner cannot plan for it)."""
    ckey = f"classes.{cls.name}"
    kind = SHAPE_KIND[cls.shape]
    sx, sy, sz = cls.size
    if kind == "cube" and max(sx, sy, sz) - min(sx, sy, sz) > 1e-6:
        raise SiteError(_where(site, f"{ckey}.size: the planner grasps boxes as cubes "
                                      "(three equal sides)"))  # fmt: skip
    if kind == "bowl" and (abs(sx - sy) > 1e-6 or abs(sz - BOWL_HEIGHT) > 1e-6):
        raise SiteError(_where(site, f"{ckey}.size: the planner's containers are square "
                                      f"and {BOWL_HEIGHT} m high"))  # fmt: skip
    if kind != "cube" and cls.graspable != (kind == "lid"):
        raise SiteError(_where(site, f"{ckey}.graspable: the planner grasps boxes and lids, "
                                      "not containers"))  # fmt: skip
    colour = colour or "white"
    if colour not in COLOURS:
        raise SiteError(_where(site, f"{key}.colour: one of {', '.join(COLOURS)}"))
    x0, y0, x1, y1 = site.place(place).region.bounds
    dx, dy = at[0] - (x0 + x1) / 2, at[1] - (y0 + y1) / 2
    try:
        return ObjectConfig(name, kind, place, round(dx, 4), round(dy, 4), colour, float(sx))
    except ValueError as e:
        raise SiteError(_where(site, f"{key}: {e}")) from None


def scene_config(site: Site, base: tuple[float, float, float]) -> SceneConfig:
    """The site as the planner's scene configuration (``base``: where TF has the robot)."""
    tables = []
    for place in site.places:
        key = f"places.{place.name}"
        if place.kind != "surface":
            raise SiteError(
                _where(
                    site,
                    f"{key}.kind: the planner plans on surfaces only "
                    "(a container is an object class: shape container)",
                )
            )
        if abs(place.region.height - TABLE_TOP) > 0.01:
            raise SiteError(
                _where(
                    site,
                    f"{key}: height {place.region.height}: the planner's "
                    f"skills place on surfaces {TABLE_TOP} m high",
                )
            )
        if not place.region.axis_aligned:
            raise SiteError(
                _where(
                    site,
                    f"{key}: the planner samples placements on axis-aligned "
                    "rectangles (give a box with yaw 0 or a rectangle)",
                )
            )
        x0, y0, x1, y1 = place.region.bounds
        tables.append(TableConfig(place.name, (x0 + x1) / 2, (y0 + y1) / 2))
    objects = []
    first = site.places[0]
    for told in site.objects:
        place = site.place(told.place) if told.place else first
        x0, y0, x1, y1 = place.region.bounds
        at = told.at or ((x0 + x1) / 2, (y0 + y1) / 2)
        objects.append(object_config(site, told.name, site.cls(told.cls), place.name, at,
                                     told.colour, f"objects.{told.name}"))  # fmt: skip
    return SceneConfig(tuple(tables), tuple(objects), base)


class SiteScene(Scene):
    """A planning scene from a site and the robot's description (a :class:`Scene`: the
    planner's streams and skills run on it unchanged)."""

    def __init__(self, client: int, site: Site, arm: ArmModel,
                 base: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:  # fmt: skip
        self.client = client
        self.site = site
        self.arm_model = arm
        self.config = scene_config(site, base)
        self.bodies: dict[str, int] = {}
        self.tables = {pl.name: Rect(*pl.region.bounds) for pl in site.places}
        self.mount = arm.mount
        self.husky, self.panda = self._load_robot()
        self.bodies["floor"] = self._box((50.0, 50.0, 0.01), (0.0, 0.0, -0.01))
        for item in site.furniture:
            x, y, z, yaw = item.pose
            half = tuple(v / 2 for v in item.size)
            self.bodies[f"furniture:{item.name}"] = self._box(half, (x, y, z), yaw)
        unknown = {o.name for o in site.objects if not o.place}
        for o in self.config.objects:
            self.bodies[o.name] = self._load_object(o)
            if o.name in unknown:
                self.set_pose(o.name, PARKED)
        self.names = {b: n for n, b in self.bodies.items()}
        self.held = None
        self._grip = None
        self._constraint = None
        self.set_base(*base)
        self.set_arm(HOME_CONF)
        self.set_fingers(FINGER_OPEN)
        self.settle()
        for name in unknown:
            self.set_pose(name, PARKED)

    def add_object(self, o: ObjectConfig, at: tuple[float, float, float]) -> None:
        """An object the robot saw that the site did not tell of, where it was seen."""
        self.config = replace(self.config, objects=(*self.config.objects, o))
        body = self._load_object(o)
        self.bodies[o.name] = body
        self.names[body] = o.name
        self.set_pose(o.name, at)

    def _box(self, half: tuple[float, ...], at: tuple[float, float, float], yaw: float = 0.0,
             mass: float = 0.0) -> int:  # fmt: skip
        c = self.client
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=c)
        quat = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        return int(p.createMultiBody(mass, shape, -1, list(at), quat, physicsClientId=c))

    def _load_robot(self) -> tuple[int, int]:
        """The base (its collision boxes, one fixed body) and the arm (the description's
        subtree, loaded from a temporary file that is removed at once)."""
        c, arm = self.client, self.arm_model
        if arm.base:
            shapes = [b.half for b in arm.base]
            col = p.createCollisionShapeArray(
                [p.GEOM_BOX] * len(shapes),
                halfExtents=[list(h) for h in shapes],
                collisionFramePositions=[list(b.centre) for b in arm.base],
                collisionFrameOrientations=[[0, 0, math.sin(b.yaw / 2), math.cos(b.yaw / 2)]
                                            for b in arm.base],
                physicsClientId=c,
            )  # fmt: skip
        else:
            col = p.createCollisionShape(p.GEOM_SPHERE, radius=0.01, physicsClientId=c)
        husky = int(p.createMultiBody(0.0, col, -1, [0, 0, 0], physicsClientId=c))
        with tempfile.TemporaryDirectory(prefix="llmpas-arm-") as folder:
            path = Path(folder) / "arm.urdf"
            path.write_text(arm.urdf, encoding="utf-8")
            with quiet_fds():
                try:
                    # no self-collision in the physics: the collision boxes of neighbouring
                    # links overlap (the planner checks self-collision pairs itself)
                    panda = p.loadURDF(str(path), [0, 0, 0], useFixedBase=True, physicsClientId=c)
                except p.error as e:
                    raise DescriptionError(f"PyBullet cannot load the arm: {e}") from None
        names = [p.getJointInfo(panda, j, physicsClientId=c)[1].decode()
                 for j in range(p.getNumJoints(panda, physicsClientId=c))]  # fmt: skip
        self._check_layout(names)
        self.bodies["base"] = husky
        self.bodies["panda"] = panda
        for j in FINGER_JOINTS:
            p.changeDynamics(panda, j, lateralFriction=1.5, spinningFriction=0.01,
                             physicsClientId=c)  # fmt: skip
        return husky, panda

    def _check_layout(self, names: list[str]) -> None:
        """The planner's kinematics index the Panda's joints (arm 0-6, fingers 9 and 10, the
        grasp frame 11): the description's arm must have them there."""
        arm_names = [names[j] for j in ARM_JOINTS if j < len(names)]
        expected = list(self.arm_model.joints[: len(ARM_JOINTS)])
        if len(names) <= EE_LINK or arm_names != expected:
            raise DescriptionError(
                "the planner's kinematics need a 7-joint arm with a two-finger hand laid out as "
                f"the Franka Panda's (joints {', '.join(names) or 'none'})"
            )
        fingers = [names[j] for j in FINGER_JOINTS]
        if any("finger" not in n for n in fingers):
            raise DescriptionError(f"no finger joints where the planner expects them: {fingers}")

    def set_base(self, x: float, y: float, yaw: float) -> None:
        c = self.client
        quat = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        p.resetBasePositionAndOrientation(self.husky, [x, y, 0.0], quat, physicsClientId=c)
        mx, my, mz, myaw = self.mount
        px = x + mx * math.cos(yaw) - my * math.sin(yaw)
        py = y + mx * math.sin(yaw) + my * math.cos(yaw)
        turn = yaw + myaw
        q2 = (0.0, 0.0, math.sin(turn / 2), math.cos(turn / 2))
        p.resetBasePositionAndOrientation(self.panda, [px, py, mz], q2, physicsClientId=c)

    def base_pose(self) -> tuple[float, float, float]:
        pos, orn = p.getBasePositionAndOrientation(self.husky, physicsClientId=self.client)
        return (float(pos[0]), float(pos[1]), float(p.getEulerFromQuaternion(orn)[2]))

    def region_at(self, x: float, y: float) -> str | None:
        return self.site.place_of(x, y)

    def movable(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.config.objects)


def heading(a: np.ndarray, b: np.ndarray) -> float:
    return float(math.atan2(b[1] - a[1], b[0] - a[0]))


__all__ = ["PARKED", "SiteScene", "scene_config"]
