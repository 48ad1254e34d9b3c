"""The PyBullet scene: a Husky with a Franka Panda on top, two tables, a bowl, cubes and lids.

With ``SceneConfig(mount="pedestal")`` the Panda stands on a fixed pedestal instead of the Husky
(the same mount height; the pedestal takes the Husky's place, so base poses, the mast camera and
the mount-contact filter of the collision checks work unchanged).

A :class:`Scene` lives in one physics client that the caller owns (``open_client`` is a context
manager that connects and always disconnects); nothing here is module-global and nothing connects
at import. The Husky is kinematic: the base moves by resetting the Husky's and the Panda's poses
together (the Panda is loaded with a fixed base at the Husky pose + the mount offset).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
import pybullet as p

log = logging.getLogger(__name__)

ARM_JOINTS = (0, 1, 2, 3, 4, 5, 6)
FINGER_JOINTS = (9, 10)
EE_LINK = 11  # panda_grasptarget
HAND_LINK = 8
MOUNT_OFFSET = (0.2, 0.0, 0.405)  # Panda base relative to the Husky base
# The carry configuration: the arm folded low over the base (out of the mast camera's view).
HOME_CONF = (0.0, -1.7, 0.0, -3.0, 0.0, 1.4, 0.785)
FINGER_OPEN = 0.04
TABLE_TOP = 0.625  # top of pybullet_data's table/table.urdf at scale 1 (z of the top surface)
TABLE_SIZE = (1.5, 1.0)  # x, y extent of the table top at scale 1
BOWL_HEIGHT = 0.05  # a bowl's walls, from its origin (on the table) to the rim
LID_PLATE = 0.01  # a lid: a square plate this thick, ...
LID_KNOB = 0.04  # ... with a square knob this wide and this high on its centre (to grasp)
RIM_MARGIN = 0.015  # m: an object whose bottom is less far below a bowl's rim is not in it
KINDS = ("cube", "bowl", "lid")
GRASPABLE = ("cube", "lid")

COLOURS: Mapping[str, tuple[float, float, float, float]] = MappingProxyType(
    {
        "green": (0.1, 0.75, 0.2, 1.0),
        "black": (0.05, 0.05, 0.05, 1.0),
        "red": (0.85, 0.1, 0.1, 1.0),
        "blue": (0.1, 0.2, 0.85, 1.0),
        "white": (0.92, 0.92, 0.92, 1.0),
    }
)


@contextlib.contextmanager
def quiet_fds() -> Iterator[None]:
    """Silence C-level stdout/stderr (URDF warnings) for the duration of the block."""
    saved: list[int] = []
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # pragma: no cover - no /dev/null
        yield
        return
    try:
        for fd in (1, 2):
            try:
                saved.append(os.dup(fd))
                os.dup2(devnull, fd)
            except OSError:  # pragma: no cover - fd closed (e.g. some test runners)
                saved.append(-1)
        yield
    finally:
        for fd, old in zip((1, 2), saved, strict=False):
            if old >= 0:
                os.dup2(old, fd)
                os.close(old)
        os.close(devnull)


@contextlib.contextmanager
def open_client(gui: bool = False, data: bool = True) -> Iterator[int]:
    """A fresh physics client (DIRECT unless ``gui``), disconnected on exit; ``data``: with
    pybullet_data's models on its search path (a planning scene built from a robot's
    description and a site needs none)."""
    with quiet_fds():
        cid = p.connect(p.GUI if gui else p.DIRECT)
    if cid < 0:
        raise RuntimeError("could not connect to PyBullet")
    try:
        if data:
            import pybullet_data

            p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        yield cid
    finally:
        with contextlib.suppress(Exception):
            p.disconnect(physicsClientId=cid)


# --------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class TableConfig:
    """A table: its name (a region for the planner) and its centre pose on the floor."""

    name: str
    x: float
    y: float
    yaw: float = 0.0  # only 0 or pi/2 (axis-aligned footprints)
    # the top's x, y extent (before yaw); None: pybullet_data's table (TABLE_SIZE); given: a
    # table of boxes (a top and four legs), TABLE_TOP high
    size: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("a table needs a name")
        if self.size is not None and not all(0.3 <= v <= 3.0 for v in self.size):
            raise ValueError(f"table {self.name!r}: size {self.size} out of [0.3, 3] m")
        turns = self.yaw / (math.pi / 2)
        if abs(turns - round(turns)) > 1e-6:
            raise ValueError(f"table {self.name!r}: yaw must be a multiple of pi/2")


@dataclass(frozen=True)
class ObjectConfig:
    """A movable object: a cube (``size`` = edge), a bowl (``size`` = outer width) or a lid (a
    square plate of width ``size`` with a knob to grasp it by), resting on ``table`` at (``dx``,
    ``dy``) from the table centre (world axes)."""

    name: str
    kind: str  # "cube" | "bowl" | "lid"
    table: str
    dx: float
    dy: float
    colour: str = "green"
    size: float = 0.05

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"object {self.name!r}: kind must be one of {', '.join(KINDS)}")
        if self.colour not in COLOURS:
            raise ValueError(f"object {self.name!r}: unknown colour {self.colour!r}")
        if not 0.01 <= self.size <= 0.4:
            raise ValueError(f"object {self.name!r}: size {self.size} out of [0.01, 0.4]")
        if self.kind == "lid" and self.size <= LID_KNOB:
            raise ValueError(f"lid {self.name!r}: size {self.size} not wider than its knob")

    @property
    def height(self) -> float:
        """From its bottom to its top."""
        if self.kind == "cube":
            return self.size
        return BOWL_HEIGHT if self.kind == "bowl" else LID_PLATE + LID_KNOB

    @property
    def origin_height(self) -> float:
        """How far its pose's z is above its bottom (a graspable object's pose is its centre,
        a bowl's its bottom)."""
        return self.height / 2 if self.graspable else 0.0

    @property
    def graspable(self) -> bool:
        """The gripper takes it (a cube, a lid by its knob); a graspable object's pose is its
        centre, a bowl's its bottom."""
        return self.kind in GRASPABLE


def _default_tables() -> tuple[TableConfig, ...]:
    return (TableConfig("table1", 1.6, 0.0, math.pi / 2), TableConfig("table2", 0.0, 1.9))


def _default_objects() -> tuple[ObjectConfig, ...]:
    return (
        ObjectConfig("cube", "cube", "table1", -0.33, 0.15, "green"),
        ObjectConfig("bowl", "bowl", "table2", -0.1, -0.3, "white", 0.16),
    )


@dataclass(frozen=True)
class SceneConfig:
    tables: tuple[TableConfig, ...] = field(default_factory=_default_tables)
    objects: tuple[ObjectConfig, ...] = field(default_factory=_default_objects)
    base: tuple[float, float, float] = (0.0, 0.0, 0.0)  # Husky x, y, yaw
    time_step: float = 1.0 / 240.0
    mount: str = "husky"  # what the Panda stands on: "husky" (mobile) or "pedestal" (fixed)

    def __post_init__(self) -> None:
        names = [t.name for t in self.tables] + [o.name for o in self.objects]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate names in scene: {names}")
        tables = {t.name for t in self.tables}
        for o in self.objects:
            if o.table not in tables:
                raise ValueError(f"object {o.name!r} is on unknown table {o.table!r}")
        if len(self.base) != 3:
            raise ValueError("base must be (x, y, yaw)")
        if not 0.0 < self.time_step <= 0.05:
            raise ValueError(f"time_step {self.time_step} out of (0, 0.05]")
        if self.mount not in ("husky", "pedestal"):
            raise ValueError(f"mount must be 'husky' or 'pedestal', got {self.mount!r}")

    def table(self, name: str) -> TableConfig:
        for t in self.tables:
            if t.name == name:
                return t
        raise KeyError(name)

    def obj(self, name: str) -> ObjectConfig:
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(name)


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle on the floor plane (a table top, a bowl's inside)."""

    x0: float
    y0: float
    x1: float
    y1: float

    def __post_init__(self) -> None:
        if not (self.x0 < self.x1 and self.y0 < self.y1):
            raise ValueError(f"empty rectangle {self}")

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        return (
            self.x0 + margin <= x <= self.x1 - margin and self.y0 + margin <= y <= self.y1 - margin
        )

    @property
    def center(self) -> tuple[float, float]:
        return ((self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2)

    def distance(self, x: float, y: float) -> float:
        dx = max(self.x0 - x, 0.0, x - self.x1)
        dy = max(self.y0 - y, 0.0, y - self.y1)
        return math.hypot(dx, dy)


def table_rect(t: TableConfig) -> Rect:
    sx, sy = t.size or TABLE_SIZE
    if abs(math.sin(t.yaw)) > 0.5:
        sx, sy = sy, sx
    return Rect(t.x - sx / 2, t.y - sy / 2, t.x + sx / 2, t.y + sy / 2)


# --------------------------------------------------------------------------- the scene


def _quat(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class Scene:
    """The bodies of one world in one physics client, by name."""

    def __init__(self, client: int, config: SceneConfig) -> None:
        self.client = client
        self.config = config
        self.bodies: dict[str, int] = {}
        self.tables: dict[str, Rect] = {t.name: table_rect(t) for t in config.tables}
        self.husky, self.panda = self._load_robot()  # husky: the body the Panda stands on
        self.bodies["plane"] = p.loadURDF("plane.urdf", physicsClientId=client)
        for t in config.tables:
            if t.size is not None:
                self.bodies[t.name] = self._box_table(t)
                continue
            with quiet_fds():
                self.bodies[t.name] = p.loadURDF(
                    "table/table.urdf",
                    [t.x, t.y, 0.0],
                    _quat(t.yaw),
                    useFixedBase=True,
                    physicsClientId=client,
                )
        for o in config.objects:
            self.bodies[o.name] = self._load_object(o)
        self.names: dict[int, str] = {b: n for n, b in self.bodies.items()}
        self.held: str | None = None
        self._grip: tuple[list[float], list[float]] | None = None  # object pose in the EE frame
        self._constraint: int | None = None
        self.set_base(*config.base)
        self.set_arm(HOME_CONF)
        self.set_fingers(FINGER_OPEN)
        self.settle()

    # ------------------------------------------------------------------ loading

    def _load_robot(self) -> tuple[int, int]:
        c = self.client
        with quiet_fds():
            if self.config.mount == "pedestal":
                husky = self._load_pedestal()
            else:
                husky = p.loadURDF(
                    "husky/husky.urdf", [0, 0, 0], useFixedBase=True, physicsClientId=c
                )
            panda = p.loadURDF(
                "franka_panda/panda.urdf",
                MOUNT_OFFSET,
                useFixedBase=True,
                flags=p.URDF_USE_SELF_COLLISION,
                physicsClientId=c,
            )
        self.bodies[self.config.mount] = husky
        self.bodies["panda"] = panda
        for j in range(p.getNumJoints(panda, physicsClientId=c)):
            p.changeDynamics(panda, j, linearDamping=0, angularDamping=0, physicsClientId=c)
        for j in FINGER_JOINTS:
            p.changeDynamics(
                panda, j, lateralFriction=1.5, spinningFriction=0.01, physicsClientId=c
            )
        return husky, panda

    def _load_pedestal(self) -> int:
        """A fixed grey box under the Panda's base, its frame on the floor like the Husky's."""
        c, (mx, my, mz) = self.client, MOUNT_OFFSET
        half, at = [0.1, 0.1, mz / 2], [mx, my, mz / 2]
        col = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=half, collisionFramePosition=at, physicsClientId=c
        )
        vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=half,
            visualFramePosition=at,
            rgbaColor=(0.4, 0.4, 0.4, 1),
            physicsClientId=c,
        )
        return int(p.createMultiBody(0.0, col, vis, [0, 0, 0], physicsClientId=c))

    def _box_table(self, t: TableConfig) -> int:
        """A table of ``t.size``: a 4 cm top whose surface is TABLE_TOP high, four legs."""
        assert t.size is not None
        hx, hy, top = t.size[0] / 2, t.size[1] / 2, 0.02
        leg = (TABLE_TOP - 2 * top) / 2
        half = [[hx, hy, top]] + [[0.03, 0.03, leg]] * 4
        pos = [[0.0, 0.0, TABLE_TOP - top]] + [
            [sx * (hx - 0.06), sy * (hy - 0.06), leg] for sx in (-1, 1) for sy in (-1, 1)
        ]
        c, n = self.client, len(half)
        col = p.createCollisionShapeArray(
            [p.GEOM_BOX] * n, halfExtents=half, collisionFramePositions=pos, physicsClientId=c
        )
        vis = p.createVisualShapeArray(
            [p.GEOM_BOX] * n,
            halfExtents=half,
            visualFramePositions=pos,
            rgbaColors=[[0.55, 0.4, 0.25, 1.0]] * n,
            physicsClientId=c,
        )
        return int(
            p.createMultiBody(0.0, col, vis, [t.x, t.y, 0.0], _quat(t.yaw), physicsClientId=c)
        )

    def _load_object(self, o: ObjectConfig) -> int:
        c = self.client
        rect = self.tables[o.table]
        cx, cy = rect.center
        rgba = COLOURS[o.colour]
        if o.kind == "cube":
            h = o.size / 2
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h], physicsClientId=c)
            vis = p.createVisualShape(
                p.GEOM_BOX, halfExtents=[h, h, h], rgbaColor=rgba, physicsClientId=c
            )
            body = p.createMultiBody(
                0.1, col, vis, [cx + o.dx, cy + o.dy, TABLE_TOP + h + 1e-3], physicsClientId=c
            )
            p.changeDynamics(body, -1, lateralFriction=1.2, physicsClientId=c)
            return int(body)
        if o.kind == "lid":
            return self._load_lid(o, (cx + o.dx, cy + o.dy), rgba)
        return self._load_bowl(o, (cx + o.dx, cy + o.dy), rgba)

    def _load_lid(self, o: ObjectConfig, xy: tuple[float, float], rgba: tuple[float, ...]) -> int:
        """A lid from primitives: a square plate and a knob on it (its origin: half its height
        above its bottom, as a cube's)."""
        w, k, mid = o.size / 2, LID_KNOB / 2, o.height / 2
        half = [[w, w, LID_PLATE / 2], [k, k, k]]
        pos = [[0, 0, LID_PLATE / 2 - mid], [0, 0, LID_PLATE + k - mid]]
        body = self._compound(half, pos, rgba, 0.15, (xy[0], xy[1], TABLE_TOP + mid + 1e-3))
        p.changeDynamics(body, -1, lateralFriction=1.2, physicsClientId=self.client)
        return body

    def _load_bowl(self, o: ObjectConfig, xy: tuple[float, float], rgba: tuple[float, ...]) -> int:
        """A square bowl from primitives: a bottom plate and four walls (a compound shape)."""
        w, t, hgt = o.size / 2, 0.01, BOWL_HEIGHT
        half = [[w, w, t / 2], [t / 2, w, hgt / 2], [t / 2, w, hgt / 2]]
        half += [[w, t / 2, hgt / 2], [w, t / 2, hgt / 2]]
        pos = [[0, 0, t / 2], [w - t / 2, 0, hgt / 2], [-w + t / 2, 0, hgt / 2]]
        pos += [[0, w - t / 2, hgt / 2], [0, -w + t / 2, hgt / 2]]
        return self._compound(half, pos, rgba, 0.5, (xy[0], xy[1], TABLE_TOP + 1e-3))

    def _compound(
        self,
        half: list[list[float]],
        pos: list[list[float]],
        rgba: tuple[float, ...],
        mass: float,
        at: tuple[float, float, float],
    ) -> int:
        """A body of boxes (half extents and frame positions), one colour."""
        c, n = self.client, len(half)
        col = p.createCollisionShapeArray(
            [p.GEOM_BOX] * n, halfExtents=half, collisionFramePositions=pos, physicsClientId=c
        )
        vis = p.createVisualShapeArray(
            [p.GEOM_BOX] * n,
            halfExtents=half,
            visualFramePositions=pos,
            rgbaColors=[list(rgba)] * n,
            physicsClientId=c,
        )
        return int(p.createMultiBody(mass, col, vis, list(at), physicsClientId=c))

    # ------------------------------------------------------------------ state

    def set_base(self, x: float, y: float, yaw: float) -> None:
        c = self.client
        p.resetBasePositionAndOrientation(self.husky, [x, y, 0.0], _quat(yaw), physicsClientId=c)
        mx, my, mz = MOUNT_OFFSET
        px = x + mx * math.cos(yaw) - my * math.sin(yaw)
        py = y + mx * math.sin(yaw) + my * math.cos(yaw)
        p.resetBasePositionAndOrientation(self.panda, [px, py, mz], _quat(yaw), physicsClientId=c)

    def base_pose(self) -> tuple[float, float, float]:
        pos, orn = p.getBasePositionAndOrientation(self.husky, physicsClientId=self.client)
        yaw = p.getEulerFromQuaternion(orn)[2]
        return (float(pos[0]), float(pos[1]), float(yaw))

    def arm_conf(self) -> tuple[float, ...]:
        states = p.getJointStates(self.panda, ARM_JOINTS, physicsClientId=self.client)
        return tuple(float(s[0]) for s in states)

    def set_arm(self, q: Sequence[float], hold: bool = True) -> None:
        """Teleport the arm to ``q`` (and, with ``hold``, make the motors hold it)."""
        c = self.client
        for j, v in zip(ARM_JOINTS, q, strict=True):
            p.resetJointState(self.panda, j, float(v), physicsClientId=c)
        if hold:
            p.setJointMotorControlArray(
                self.panda,
                ARM_JOINTS,
                p.POSITION_CONTROL,
                targetPositions=list(q),
                forces=[200.0] * len(ARM_JOINTS),
                physicsClientId=c,
            )

    def set_fingers(self, width: float) -> None:
        c = self.client
        for j in FINGER_JOINTS:
            p.resetJointState(self.panda, j, width, physicsClientId=c)
        self.drive_fingers(width)

    def drive_fingers(self, width: float, force: float = 40.0) -> None:
        p.setJointMotorControlArray(
            self.panda,
            FINGER_JOINTS,
            p.POSITION_CONTROL,
            targetPositions=[width, width],
            forces=[force, force],
            physicsClientId=self.client,
        )

    def finger_width(self) -> float:
        states = p.getJointStates(self.panda, FINGER_JOINTS, physicsClientId=self.client)
        return float(sum(s[0] for s in states))

    def ee_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position and quaternion (x, y, z, w) of the grasp target frame."""
        s = p.getLinkState(
            self.panda, EE_LINK, computeForwardKinematics=True, physicsClientId=self.client
        )
        return np.array(s[4]), np.array(s[5])

    def pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        pos, orn = p.getBasePositionAndOrientation(self.bodies[name], physicsClientId=self.client)
        return np.array(pos), np.array(orn)

    def set_pose(self, name: str, xyz: Sequence[float], yaw: float = 0.0) -> None:
        c = self.client
        b = self.bodies[name]
        p.resetBasePositionAndOrientation(b, list(xyz), _quat(yaw), physicsClientId=c)
        p.resetBaseVelocity(b, [0, 0, 0], [0, 0, 0], physicsClientId=c)

    def place_on(self, name: str, table: str, dx: float, dy: float) -> None:
        """Teleport an object onto a table (scenario disturbances)."""
        cx, cy = self.tables[table].center
        o = self.config.obj(name)
        z = TABLE_TOP + o.origin_height + 1e-3
        self.set_pose(name, (cx + dx, cy + dy, z))

    # ------------------------------------------------------------------ holding

    def attach(self, name: str) -> None:
        """Hold ``name`` where it is now relative to the gripper (a fixed constraint)."""
        c = self.client
        ee_pos, ee_orn = self.ee_pose()
        pos, orn = self.pose(name)
        inv_pos, inv_orn = p.invertTransform(list(ee_pos), list(ee_orn))
        rel_pos, rel_orn = p.multiplyTransforms(inv_pos, inv_orn, list(pos), list(orn))
        self._grip = (list(rel_pos), list(rel_orn))
        self.held = name
        self._constraint = p.createConstraint(
            self.panda,
            EE_LINK,
            self.bodies[name],
            -1,
            p.JOINT_FIXED,
            [0, 0, 0],
            rel_pos,
            [0, 0, 0],
            rel_orn,
            physicsClientId=c,
        )
        p.changeConstraint(self._constraint, maxForce=200, physicsClientId=c)

    def detach(self) -> None:
        if self._constraint is not None:
            p.removeConstraint(self._constraint, physicsClientId=self.client)
        self._constraint = None
        self._grip = None
        self.held = None

    def carry(self) -> None:
        """Put the held object where the gripper holds it (after a kinematic arm move)."""
        if self.held is None or self._grip is None:
            return
        ee_pos, ee_orn = self.ee_pose()
        pos, orn = p.multiplyTransforms(list(ee_pos), list(ee_orn), *self._grip)
        b = self.bodies[self.held]
        p.resetBasePositionAndOrientation(b, pos, orn, physicsClientId=self.client)
        p.resetBaseVelocity(b, [0, 0, 0], [0, 0, 0], physicsClientId=self.client)

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            p.stepSimulation(physicsClientId=self.client)

    def settle(self, steps: int = 120) -> None:
        self.step(steps)

    def save(self) -> int:
        return int(p.saveState(physicsClientId=self.client))

    def restore(self, state: int, remove: bool = True) -> None:
        p.restoreState(stateId=state, physicsClientId=self.client)
        if remove:
            p.removeState(state, physicsClientId=self.client)

    def movable(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.config.objects)

    def region_of(self, x: float, y: float, z: float | None = None) -> str | None:
        """The region (a bowl, else a table) under the point, or None."""
        for o in self.config.objects:
            if o.kind == "bowl":
                pos, _ = self.pose(o.name)
                inner = o.size / 2 - 0.01
                if abs(x - pos[0]) <= inner and abs(y - pos[1]) <= inner:
                    return o.name
        for name, rect in self.tables.items():
            if rect.contains(x, y):
                return name
        return None


@contextlib.contextmanager
def open_scene(config: SceneConfig | None = None, gui: bool = False) -> Iterator[Scene]:
    """Connect, build the scene, and disconnect on exit."""
    with open_client(gui) as cid:
        yield Scene(cid, config or SceneConfig())
