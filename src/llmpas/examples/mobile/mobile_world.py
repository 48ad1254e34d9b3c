"""The kitchen: floor, tables and a counter with a sink and a stove, objects, and the values
(poses, grasps, base configurations, trajectories) that streams produce."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Literal

import numpy as np

from llmpas.examples.mobile.mobile_geometry import BaseWorld, Box, Rect, rect_array

BASE_HALF_LENGTH = 0.33  # the base footprint: along its heading
BASE_HALF_WIDTH = 0.28  # and across
FLOOR_DEPTH = 4.5
COUNTER_DEPTH = 0.65
COUNTER_HEIGHT = 0.9
TABLE_HEIGHT = 0.75
EDGE = 0.06  # placements keep this far from the edge of a surface (plus the object radius)

GraspKind = Literal["top", "side"]
GoalKind = Literal["on", "cleaned", "cooked"]


# ----------------------------------------------------------------------------------- values


@dataclass(frozen=True)
class ObjPose:
    """An object standing on a surface: centre ``(x, y)``, surface height ``z``, yaw."""

    x: float
    y: float
    z: float
    yaw: float = 0.0


@dataclass(frozen=True)
class Grasp:
    """``top``: the gripper points down onto the object; ``side``: it approaches horizontally
    along the base's heading (a forward grasp)."""

    kind: GraspKind


@dataclass(frozen=True)
class BaseConf:
    x: float
    y: float
    theta: float

    @property
    def xy(self) -> np.ndarray:
        return np.array([self.x, self.y], dtype=float)


@dataclass(frozen=True)
class BaseTraj:
    """A drive through ``path`` (its first and last entries are the endpoints)."""

    path: tuple[BaseConf, ...]

    @property
    def length(self) -> float:
        pts = [q.xy for q in self.path]
        return float(sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(pts)))


JointConf = tuple[float, float, float]


@dataclass(frozen=True)
class ArmTraj:
    """Joint angles of ``arm`` from the tucked configuration to the grasp, the base at ``base``."""

    arm: str
    base: BaseConf
    path: tuple[JointConf, ...]


# ------------------------------------------------------------------------------ the kitchen


@dataclass(frozen=True)
class ObjectSpec:
    """A cylinder: footprint radius and height."""

    name: str
    radius: float
    height: float


@dataclass(frozen=True)
class Surface:
    """A region objects can stand on: a rectangle of a table or counter top at height ``z``."""

    name: str
    rect: Rect
    z: float
    kind: Literal["table", "sink", "stove"] = "table"


@dataclass(frozen=True)
class Goal:
    kind: GoalKind
    obj: str
    region: str | None = None  # the table of an ``on`` goal


@dataclass(frozen=True)
class Kitchen:
    floor: Rect
    obstacles: tuple[Box, ...]
    surfaces: tuple[Surface, ...]
    objects: tuple[ObjectSpec, ...]
    start: tuple[ObjPose, ...]  # in object order
    start_surface: tuple[str, ...]
    home: BaseConf
    goals: tuple[Goal, ...]

    def obj(self, name: str) -> ObjectSpec:
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(f"unknown object {name!r}")

    def surface(self, name: str) -> Surface:
        for s in self.surfaces:
            if s.name == name:
                return s
        raise KeyError(f"unknown region {name!r}")

    def of_kind(self, kind: str) -> tuple[Surface, ...]:
        return tuple(s for s in self.surfaces if s.kind == kind)

    def base_world(self) -> BaseWorld:
        """The free space of the base."""
        rects = rect_array(tuple(b.rect for b in self.obstacles))
        return BaseWorld(self.floor, rects, BASE_HALF_LENGTH, BASE_HALF_WIDTH)


def placement_area(surface: Surface, obj: ObjectSpec) -> Rect:
    """Where the centre of ``obj`` may be on ``surface``."""
    return surface.rect.inset(EDGE + obj.radius)


def supported(surface: Surface, obj: ObjectSpec, pose: ObjPose) -> bool:
    return abs(pose.z - surface.z) < 1e-9 and placement_area(surface, obj).contains(pose.x, pose.y)


# ------------------------------------------------------------------------------ generation


def make_kitchen(n_objects: int, seed: int) -> Kitchen:
    """A kitchen sized for ``n_objects`` objects, each with a goal."""
    if n_objects < 1:
        raise ValueError(f"the kitchen needs at least 1 object, got {n_objects}")
    rng = np.random.default_rng(seed)
    tables, width = _tables(max(2, (n_objects + 3) // 2), rng)
    counter, sink, stove = _counter(n_objects, width)
    chairs = _chairs(tables, rng)
    objects = tuple(
        ObjectSpec(f"o{i + 1}", float(rng.uniform(0.03, 0.05)), float(rng.uniform(0.08, 0.15)))
        for i in range(n_objects)
    )
    table_tops = tuple(
        Surface(f"table{k + 1}", t.rect.inset(0.02), TABLE_HEIGHT) for k, t in enumerate(tables)
    )
    start, where = _start(objects, table_tops, rng)
    return Kitchen(
        floor=Rect(0.0, 0.0, width, FLOOR_DEPTH),
        obstacles=(*tables, counter, *chairs),
        surfaces=(*table_tops, sink, stove),
        objects=objects,
        start=start,
        start_surface=where,
        home=BaseConf(0.6, 0.6, 0.0),
        goals=_goals(objects, where, table_tops, rng),
    )


def _tables(n: int, rng: np.random.Generator) -> tuple[tuple[Box, ...], float]:
    """``n`` tables in a row across the middle of the room, with room to drive between them."""
    out = []
    x = 1.2
    for k in range(n):
        w, d = float(rng.uniform(1.0, 1.4)), float(rng.uniform(0.6, 0.8))
        cy = float(rng.uniform(1.8, 2.1))
        out.append(Box(f"table{k + 1}", Rect(x, cy - d / 2, x + w, cy + d / 2), TABLE_HEIGHT))
        x += w + float(rng.uniform(1.0, 1.4))
    return tuple(out), x + 0.2


def _counter(n_objects: int, width: float) -> tuple[Box, Surface, Surface]:
    """A counter along the back wall; the sink at its left end, the stove at its right end."""
    y0 = FLOOR_DEPTH - COUNTER_DEPTH
    counter = Box("counter", Rect(0.0, y0, width, FLOOR_DEPTH), COUNTER_HEIGHT)
    span = 0.5 + 0.12 * n_objects
    front = (y0 + 0.02, y0 + 0.45)  # the part of the top within the arm's reach
    sink = Surface("sink", Rect(0.4, front[0], 0.4 + span, front[1]), COUNTER_HEIGHT, "sink")
    stove_x = width - 0.4 - span
    stove = Surface(
        "stove", Rect(stove_x, front[0], width - 0.4, front[1]), COUNTER_HEIGHT, "stove"
    )
    return counter, sink, stove


def _chairs(tables: tuple[Box, ...], rng: np.random.Generator) -> tuple[Box, ...]:
    """One chair in front of each table, at a random place along its front edge."""
    out = []
    for t in tables:
        r = t.rect
        cx = float(rng.uniform(r.x0 + 0.25, r.x1 - 0.25))
        out.append(Box(f"chair-{t.name}", Rect(cx - 0.2, r.y0 - 0.45, cx + 0.2, r.y0 - 0.05), 0.45))
    return tuple(out)


def _start(
    objects: tuple[ObjectSpec, ...], tables: tuple[Surface, ...], rng: np.random.Generator
) -> tuple[tuple[ObjPose, ...], tuple[str, ...]]:
    """Objects at random non-overlapping places on random tables."""
    poses: list[ObjPose] = []
    where: list[str] = []
    for o in objects:
        while True:
            t = tables[int(rng.integers(len(tables)))]
            x, y = placement_area(t, o).sample(rng)
            p = ObjPose(x, y, t.z, float(rng.uniform(-np.pi, np.pi)))
            if all(_apart(o, p, objects[k], q) for k, q in enumerate(poses)):
                poses.append(p)
                where.append(t.name)
                break
    return tuple(poses), tuple(where)


def _apart(o1: ObjectSpec, p1: ObjPose, o2: ObjectSpec, p2: ObjPose) -> bool:
    return bool(np.hypot(p1.x - p2.x, p1.y - p2.y) >= o1.radius + o2.radius + 0.01)


def footprints_apart(o1: ObjectSpec, p1: ObjPose, o2: ObjectSpec, p2: ObjPose) -> bool:
    """The two objects, at the given poses, do not overlap (with 1 cm to spare)."""
    if abs(p1.z - p2.z) > 1e-9:
        return True  # on different surfaces
    return _apart(o1, p1, o2, p2)


def _goals(
    objects: tuple[ObjectSpec, ...],
    where: tuple[str, ...],
    tables: tuple[Surface, ...],
    rng: np.random.Generator,
) -> tuple[Goal, ...]:
    """Goal kinds cycle through on/cleaned/cooked from a random offset; ``on`` moves the object
    to another table."""
    kinds: tuple[GoalKind, ...] = ("on", "cleaned", "cooked")
    offset = int(rng.integers(3))
    out = []
    for i, o in enumerate(objects):
        kind = kinds[(i + offset) % 3]
        if kind == "on":
            others = [t.name for t in tables if t.name != where[i]]
            out.append(Goal("on", o.name, others[int(rng.integers(len(others)))]))
        else:
            out.append(Goal(kind, o.name))
    return tuple(out)
