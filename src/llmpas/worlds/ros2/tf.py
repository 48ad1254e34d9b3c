"""A small TF buffer: the transforms of ``/tf`` and ``/tf_static``, looked up through chains.

``tf2_ros`` has no PyPI wheel; this is the part of it llmpas needs. Each child frame has one
parent; dynamic transforms are kept per child in time order (a bounded history), static ones
once. :meth:`TfBuffer.lookup` answers ``target <- source`` at a time (the latest when ``None``),
interpolating a dynamic edge between the two nearest stamps (position linearly, rotation by
slerp) and refusing a time outside an edge's history by more than ``tolerance``. Plain data in,
no rclpy: a subscriber feeds :meth:`TfBuffer.add` from ``tf2_msgs/TFMessage``.
"""

from __future__ import annotations

import bisect
import math
import threading
from dataclasses import dataclass

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w


class TfError(LookupError):
    """No chain between two frames, or none at that time."""


@dataclass(frozen=True)
class Transform:
    """A rigid transform: a point ``p`` of the child frame is ``R(rotation) p + translation``
    in the parent frame."""

    translation: Vec = (0.0, 0.0, 0.0)
    rotation: Quat = (0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        n = math.sqrt(sum(v * v for v in self.rotation))
        if not all(math.isfinite(v) for v in (*self.translation, *self.rotation)) or n < 1e-9:
            raise ValueError("a transform needs finite numbers and a non-zero quaternion")
        if abs(n - 1.0) > 1e-9:
            object.__setattr__(self, "rotation", tuple(v / n for v in self.rotation))

    def __mul__(self, other: Transform) -> Transform:
        """``self`` after ``other``: parent <- self.child == other.parent <- other.child."""
        return Transform(_add(self.translation, _rotate(self.rotation, other.translation)),
                         _qmul(self.rotation, other.rotation))  # fmt: skip

    def inverse(self) -> Transform:
        qi = (-self.rotation[0], -self.rotation[1], -self.rotation[2], self.rotation[3])
        t = _rotate(qi, self.translation)
        return Transform((-t[0], -t[1], -t[2]), qi)

    def apply(self, point: Vec) -> Vec:
        return _add(self.translation, _rotate(self.rotation, point))

    @property
    def yaw(self) -> float:
        x, y, z, w = self.rotation
        return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))

    @staticmethod
    def planar(x: float, y: float, yaw: float, z: float = 0.0) -> Transform:
        return Transform((x, y, z), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))


def _add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _qmul(a: Quat, b: Quat) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def _rotate(q: Quat, v: Vec) -> Vec:
    x, y, z, _ = _qmul(_qmul(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def _slerp(a: Quat, b: Quat, t: float) -> Quat:
    dot = sum(u * v for u, v in zip(a, b, strict=True))
    if dot < 0:
        b, dot = (-b[0], -b[1], -b[2], -b[3]), -dot
    if dot > 0.9995:
        q = tuple(u + (v - u) * t for u, v in zip(a, b, strict=True))
    else:
        theta = math.acos(dot)
        sa, sb = math.sin((1 - t) * theta), math.sin(t * theta)
        q = tuple((u * sa + v * sb) / math.sin(theta) for u, v in zip(a, b, strict=True))
    n = math.sqrt(sum(v * v for v in q))
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def _interpolate(a: Transform, b: Transform, t: float) -> Transform:
    pos = tuple(u + (v - u) * t for u, v in zip(a.translation, b.translation, strict=True))
    return Transform((pos[0], pos[1], pos[2]), _slerp(a.rotation, b.rotation, t))


@dataclass
class _Edge:
    parent: str
    static: bool
    stamps: list[float]
    values: list[Transform]


class TfBuffer:
    """Stamped transforms by child frame; thread-safe (a subscriber thread adds, the loop looks
    up). ``history``: how many dynamic transforms each frame keeps; ``tolerance``: how far (s)
    outside an edge's history a lookup may still take its nearest transform."""

    def __init__(self, history: int = 200, tolerance: float = 0.5) -> None:
        if history < 2 or tolerance < 0:
            raise ValueError("history >= 2 and tolerance >= 0")
        self.history, self.tolerance = history, tolerance
        self._edges: dict[str, _Edge] = {}
        self._lock = threading.Lock()

    def add(self, parent: str, child: str, stamp: float, transform: Transform,
            static: bool = False) -> None:  # fmt: skip
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if not parent or not child or parent == child:
            raise ValueError(f"a transform from {parent!r} to {child!r}")
        with self._lock:
            edge = self._edges.get(child)
            if edge is None or edge.parent != parent or edge.static != static:
                edge = self._edges[child] = _Edge(parent, static, [], [])
            if static:
                edge.stamps[:], edge.values[:] = [stamp], [transform]
                return
            i = bisect.bisect_right(edge.stamps, stamp)
            if i and edge.stamps[i - 1] == stamp:
                edge.values[i - 1] = transform
                return
            edge.stamps.insert(i, stamp)
            edge.values.insert(i, transform)
            if len(edge.stamps) > self.history:
                del edge.stamps[0], edge.values[0]

    def frames(self) -> set[str]:
        with self._lock:
            return set(self._edges) | {e.parent for e in self._edges.values()}

    def _at(self, child: str, edge: _Edge, stamp: float | None) -> Transform:
        if edge.static or stamp is None:
            return edge.values[-1]
        s = edge.stamps
        if stamp <= s[0] or stamp >= s[-1]:
            k, gap = (0, s[0] - stamp) if stamp <= s[0] else (-1, stamp - s[-1])
            if gap > self.tolerance:
                raise TfError(
                    f"{edge.parent} -> {child}: no transform at {stamp:.3f} "
                    f"(known {s[0]:.3f}..{s[-1]:.3f})"
                )
            return edge.values[k]
        i = bisect.bisect_left(s, stamp)
        t0, t1 = s[i - 1], s[i]
        return _interpolate(edge.values[i - 1], edge.values[i], (stamp - t0) / (t1 - t0))

    def _to_root(self, frame: str, stamp: float | None) -> tuple[str, Transform]:
        """The root of ``frame``'s tree and ``root <- frame``."""
        out = Transform()
        seen = {frame}
        while frame in self._edges:
            edge = self._edges[frame]
            out = self._at(frame, edge, stamp) * out
            frame = edge.parent
            if frame in seen:
                raise TfError(f"a loop in the transforms at {frame}")
            seen.add(frame)
        return frame, out

    def lookup(self, target: str, source: str, stamp: float | None = None) -> Transform:
        """``target <- source`` (a point of ``source`` expressed in ``target``) at ``stamp``
        (seconds; ``None``: the latest of every edge). :class:`TfError` when no chain joins
        them or an edge has nothing near that time."""
        target, source = target.lstrip("/"), source.lstrip("/")
        if target == source:
            return Transform()
        with self._lock:
            root_s, from_source = self._to_root(source, stamp)
            root_t, from_target = self._to_root(target, stamp)
        if root_s != root_t:
            raise TfError(f"no transform chain from {source} to {target}")
        return from_target.inverse() * from_source


__all__ = ["TfBuffer", "TfError", "Transform"]
