"""Planar geometry for the kitchen: axis-aligned boxes on the floor and a rectangular base."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle ``[x0, x1] x [y0, y1]`` on the floor plane."""

    x0: float
    y0: float
    x1: float
    y1: float

    def __post_init__(self) -> None:
        if self.x1 < self.x0 or self.y1 < self.y0:
            raise ValueError(f"empty rectangle {self}")

    @property
    def center(self) -> tuple[float, float]:
        return (self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2

    def inset(self, d: float) -> Rect:
        """The rectangle shrunk by ``d`` on every side (clamped to its centre line)."""
        cx, cy = self.center
        return Rect(
            min(self.x0 + d, cx), min(self.y0 + d, cy), max(self.x1 - d, cx), max(self.y1 - d, cy)
        )

    def contains(self, x: float, y: float, tol: float = 1e-9) -> bool:
        return self.x0 - tol <= x <= self.x1 + tol and self.y0 - tol <= y <= self.y1 + tol

    def sample(self, rng: np.random.Generator) -> tuple[float, float]:
        return float(rng.uniform(self.x0, self.x1)), float(rng.uniform(self.y0, self.y1))


@dataclass(frozen=True)
class Box:
    """A named obstacle standing on the floor: a footprint and a height (tables, counters)."""

    name: str
    rect: Rect
    height: float


def rect_array(rects: tuple[Rect, ...]) -> FloatArray:
    """``(k, 4)`` array of ``x0, y0, x1, y1``."""
    return np.array([[r.x0, r.y0, r.x1, r.y1] for r in rects], dtype=float).reshape(-1, 4)


@dataclass(frozen=True)
class BaseWorld:
    """Where the robot base may stand: a rectangular footprint (``half_length`` along its
    heading, ``half_width`` across) inside ``bounds`` and clear of every obstacle footprint.
    Configurations are ``(x, y, theta)`` rows; the check is the separating-axis test."""

    bounds: Rect
    obstacles: FloatArray  # (k, 4) footprints x0, y0, x1, y1
    half_length: float
    half_width: float
    margin: float = 0.02

    def free(self, confs: FloatArray) -> BoolArray:
        """Which of the ``(n, 3)`` configurations are collision-free."""
        q = np.atleast_2d(confs)
        c, s = np.abs(np.cos(q[:, 2])), np.abs(np.sin(q[:, 2]))
        a, b = self.half_length + self.margin, self.half_width + self.margin
        ext_x, ext_y = a * c + b * s, a * s + b * c  # half extents along the world axes
        bd = self.bounds
        ok = (q[:, 0] - ext_x >= bd.x0) & (q[:, 0] + ext_x <= bd.x1)
        ok &= (q[:, 1] - ext_y >= bd.y0) & (q[:, 1] + ext_y <= bd.y1)
        if self.obstacles.shape[0] == 0:
            return np.asarray(ok)
        return np.asarray(ok & ~self._hits(q, ext_x, ext_y).any(axis=1))

    def _hits(self, q: FloatArray, ext_x: FloatArray, ext_y: FloatArray) -> BoolArray:
        """``(n, k)``: configuration i overlaps obstacle j (no separating axis among four)."""
        o = self.obstacles
        ox, oy = (o[:, 0] + o[:, 2]) / 2, (o[:, 1] + o[:, 3]) / 2
        hw, hh = (o[:, 2] - o[:, 0]) / 2, (o[:, 3] - o[:, 1]) / 2
        dx, dy = q[:, 0:1] - ox[None, :], q[:, 1:2] - oy[None, :]
        cos, sin = np.cos(q[:, 2:3]), np.sin(q[:, 2:3])
        ac, as_ = np.abs(cos), np.abs(sin)
        a, b = self.half_length + self.margin, self.half_width + self.margin
        hit = (np.abs(dx) < ext_x[:, None] + hw) & (np.abs(dy) < ext_y[:, None] + hh)
        hit &= np.abs(dx * cos + dy * sin) < a + hw * ac + hh * as_
        hit &= np.abs(-dx * sin + dy * cos) < b + hw * as_ + hh * ac
        return np.asarray(hit)

    def segment_free(
        self, q1: FloatArray, q2: FloatArray, resolution: float, angular_resolution: float
    ) -> bool:
        """Every configuration on the straight SE(2) segment (shortest turn) is free."""
        turn = wrap_angle(float(q2[2] - q1[2]))
        n = max(
            int(np.ceil(float(np.hypot(*(q2[:2] - q1[:2]))) / resolution)),
            int(np.ceil(abs(turn) / angular_resolution)),
            1,
        )
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        pts = np.hstack([q1[None, :2] * (1 - t) + q2[None, :2] * t, q1[2] + turn * t])
        return bool(self.free(pts).all())


def wrap_angle(a: float) -> float:
    """``a`` in ``[-pi, pi)``."""
    return float((a + np.pi) % (2 * np.pi) - np.pi)
