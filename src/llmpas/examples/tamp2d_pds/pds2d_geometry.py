"""Geometry of the pds-tamp2d domain: a vertical 2-D world (x along the ground, y up).

Blocks are rectangles standing on the ground (y = 0); a pose is the centre of a block. A robot is
a suction gripper, a small rectangle centred on its configuration (a point); a grasp is the offset
from the block's centre to the gripper's centre, so holding block ``b`` at pose ``p`` with grasp
``g`` puts the gripper at ``p + g``. Fixed obstacles (walls) stand on the ground. Paths are
collision-checked at points ``RESOLUTION`` apart, with numpy.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from llmpas.examples.mobile.mobile_geometry import Rect, rect_array
from llmpas.examples.tamp2d.tamp2d_world import Conf, Traj

GRIPPER_WIDTH = 0.4
GRIPPER_HEIGHT = 0.3
RESOLUTION = 0.05  # distance between collision-checked points along a path
MARGIN = 1e-6  # touching is not colliding


@dataclass(frozen=True)
class Pose:
    """Where a block stands: the centre of its rectangle."""

    x: float
    y: float


@dataclass(frozen=True)
class Grasp:
    """Offset from a block's centre to the centre of the gripper holding it."""

    dx: float
    dy: float


def overlaps(a: Rect, b: Rect) -> bool:
    """The two rectangles share more than a boundary."""
    return bool(
        a.x0 < b.x1 - MARGIN
        and b.x0 < a.x1 - MARGIN
        and a.y0 < b.y1 - MARGIN
        and b.y0 < a.y1 - MARGIN
    )


@dataclass(frozen=True)
class Block:
    name: str
    width: float
    height: float

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"block {self.name!r} needs a positive size")

    def rect(self, p: Pose) -> Rect:
        w, h = self.width / 2, self.height / 2
        return Rect(p.x - w, p.y - h, p.x + w, p.y + h)

    def resting(self, x: float) -> Pose:
        """The pose standing on the ground with its centre above ``x``."""
        return Pose(float(x), self.height / 2)


@dataclass(frozen=True)
class Region:
    """An interval of the ground, ``[lo, hi]`` along x."""

    name: str
    lo: float
    hi: float

    def __post_init__(self) -> None:
        if self.hi <= self.lo:
            raise ValueError(f"region {self.name!r} is empty")

    def contains(self, block: Block, p: Pose) -> bool:
        r = block.rect(p)
        return self.lo - MARGIN <= r.x0 and r.x1 <= self.hi + MARGIN and abs(r.y0) <= MARGIN


def gripper_rect(q: Conf) -> Rect:
    w, h = GRIPPER_WIDTH / 2, GRIPPER_HEIGHT / 2
    return Rect(q.x - w, q.y - h, q.x + w, q.y + h)


def grasp_conf(p: Pose, g: Grasp) -> Conf:
    """Forward kinematics of a grasp: where the gripper is when it holds a block at ``p``."""
    return Conf(p.x + g.dx, p.y + g.dy)


def held_pose(q: Conf, g: Grasp) -> Pose:
    """Where a block held with ``g`` is when the gripper is at ``q``."""
    return Pose(q.x - g.dx, q.y - g.dy)


def close(a: Conf | Pose, b: Conf | Pose, tol: float = 1e-6) -> bool:
    return abs(a.x - b.x) <= tol and abs(a.y - b.y) <= tol


def sample_path(waypoints: tuple[Conf, ...], resolution: float = RESOLUTION) -> np.ndarray:
    """Points along the polyline at most ``resolution`` apart, endpoints included: (k, 2)."""
    pts = np.array([(q.x, q.y) for q in waypoints], dtype=float)
    if len(pts) == 1:
        return pts
    out = [pts[:1]]
    for a, b in itertools.pairwise(pts):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / resolution)))
        t = np.linspace(0.0, 1.0, n + 1)[1:, None]
        out.append(a + t * (b - a))
    return np.concatenate(out)


def swept_hits(centres: np.ndarray, half: tuple[float, float], rects: list[Rect]) -> np.ndarray:
    """For a rectangle of half-size ``half`` centred at each row of ``centres``: whether it
    overlaps any of ``rects`` (a boolean per centre)."""
    if not rects:
        return np.zeros(len(centres), dtype=bool)
    r = rect_array(tuple(rects))[None, :, :]  # (1, m, 4)
    c = centres[:, None, :]  # (k, 1, 2)
    hx, hy = half
    hit = (
        (c[..., 0] - hx < r[..., 2] - MARGIN)
        & (r[..., 0] < c[..., 0] + hx - MARGIN)
        & (c[..., 1] - hy < r[..., 3] - MARGIN)
        & (r[..., 1] < c[..., 1] + hy - MARGIN)
    )
    return np.asarray(hit.any(axis=1))


GRIPPER_HALF = (GRIPPER_WIDTH / 2, GRIPPER_HEIGHT / 2)


__all__ = [
    "GRIPPER_HALF",
    "GRIPPER_HEIGHT",
    "GRIPPER_WIDTH",
    "RESOLUTION",
    "Block",
    "Conf",
    "Grasp",
    "Pose",
    "Rect",
    "Region",
    "Traj",
    "close",
    "grasp_conf",
    "gripper_rect",
    "held_pose",
    "overlaps",
    "sample_path",
    "swept_hits",
]
