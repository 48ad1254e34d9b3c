"""Base motion planning in SE(2) for a differential-drive base with a rectangular footprint:
RRT-Connect among boxes, then shortcut smoothing.

Every edge is executed the way a differential drive moves: turn in place to face the travel
direction (driving forwards or in reverse), drive straight, turn in place to the final heading.
Distances for the nearest-neighbour search weigh turning by ``turn_weight`` metres per radian."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from llmpas.examples.mobile.mobile_geometry import BaseWorld, FloatArray, wrap_angle
from llmpas.examples.mobile.mobile_world import BaseConf, BaseTraj


@dataclass(frozen=True)
class RRTParams:
    step: float = 0.3  # longest tree edge (SE(2) metric)
    resolution: float = 0.01  # translation between collision checks along an edge (m)
    angular_resolution: float = 0.02  # rotation between collision checks (rad)
    turn_weight: float = 0.4  # metres per radian in the distance
    max_iterations: int = 2000
    goal_bias: float = 0.1
    shortcuts: int = 80
    straight_steps: int = 3  # how far a blocked extension may drive straight instead


def _delta(a: FloatArray, b: FloatArray) -> FloatArray:
    """``b - a`` with the shortest turn."""
    d = b - a
    d[..., 2] = (d[..., 2] + np.pi) % (2 * np.pi) - np.pi
    return d


class _Tree:
    """Configurations in a growing array, with parent links."""

    def __init__(self, root: FloatArray) -> None:
        self.nodes = np.empty((64, 3))
        self.nodes[0] = root
        self.parents = [-1]

    @property
    def size(self) -> int:
        return len(self.parents)

    def nearest(self, q: FloatArray, w: float) -> int:
        d = _delta(self.nodes[: self.size], q[None, :])
        d[:, 2] *= w
        return int(np.argmin(np.einsum("ij,ij->i", d, d)))

    def add(self, q: FloatArray, parent: int) -> int:
        if self.size == self.nodes.shape[0]:
            self.nodes = np.vstack([self.nodes, np.empty_like(self.nodes)])
        self.nodes[self.size] = q
        self.parents.append(parent)
        return self.size - 1

    def branch(self, i: int) -> list[FloatArray]:
        """Configurations from node ``i`` up to the root."""
        out = []
        while i >= 0:
            out.append(self.nodes[i].copy())
            i = self.parents[i]
        return out


def _steer(a: FloatArray, b: FloatArray, p: RRTParams) -> FloatArray:
    """``b`` if it is within a step; otherwise a step's drive towards it, facing the way."""
    d = b[:2] - a[:2]
    n = float(np.hypot(d[0], d[1]))
    if n <= p.step:
        return b.copy()
    xy = a[:2] + d * (p.step / n)
    return np.array([xy[0], xy[1], np.arctan2(d[1], d[0])])


def _headings(a: FloatArray, b: FloatArray) -> list[float]:
    """Travel headings for the drive from ``a`` to ``b``: forwards and in reverse, the one
    needing less turning first; none when the two positions coincide."""
    dx, dy = float(b[0] - a[0]), float(b[1] - a[1])
    if np.hypot(dx, dy) < 1e-9:
        return []
    fwd = float(np.arctan2(dy, dx))
    options = [fwd, wrap_angle(fwd + np.pi)]

    def turning(h: float) -> float:
        return abs(wrap_angle(h - float(a[2]))) + abs(wrap_angle(float(b[2]) - h))

    return sorted(options, key=turning)


def edge_waypoints(
    a: FloatArray, b: FloatArray, world: BaseWorld, p: RRTParams
) -> list[FloatArray] | None:
    """Turn, drive, turn from ``a`` to ``b`` (``a`` excluded, ``b`` included) if collision-free."""
    heads = _headings(a, b)
    if not heads:
        return [b.copy()] if world.segment_free(a, b, p.resolution, p.angular_resolution) else None
    for h in heads:
        legs = [np.array([a[0], a[1], h]), np.array([b[0], b[1], h]), b.copy()]
        starts = [a, *legs[:-1]]
        if all(
            world.segment_free(u, v, p.resolution, p.angular_resolution)
            for u, v in zip(starts, legs, strict=True)
        ):
            return legs
    return None


def _edge_free(world: BaseWorld, a: FloatArray, b: FloatArray, p: RRTParams) -> bool:
    return edge_waypoints(a, b, world, p) is not None


def _step_from(
    tree: _Tree, i: int, target: FloatArray, world: BaseWorld, p: RRTParams
) -> int | None:
    """Add one step from node ``i`` towards ``target``; the new node, or None when blocked."""
    new = _steer(tree.nodes[i], target, p)
    if not _edge_free(world, tree.nodes[i], new, p):
        return None
    return tree.add(new, i)


def _extend(tree: _Tree, target: FloatArray, world: BaseWorld, p: RRTParams) -> int | None:
    """One step of ``tree`` from its nearest node towards ``target``; when that is blocked, a
    straight drive along the node's heading (forwards or back, whichever gets closer) for up to
    ``straight_steps`` steps: the only way out of spots too tight to turn in."""
    i = tree.nearest(target, p.turn_weight)
    new = _step_from(tree, i, target, world, p)
    if new is not None:
        return new
    a = tree.nodes[i]
    ahead = np.array([np.cos(a[2]), np.sin(a[2])])
    sign = 1.0 if float(np.dot(target[:2] - a[:2], ahead)) >= 0 else -1.0
    last = None
    for _ in range(p.straight_steps):
        b = tree.nodes[i]
        straight = np.array([*(b[:2] + sign * p.step * ahead), b[2]])
        if not world.segment_free(b, straight, p.resolution, p.angular_resolution):
            break
        i = last = tree.add(straight, i)
    return last


def _connect(tree: _Tree, target: FloatArray, world: BaseWorld, p: RRTParams) -> int | None:
    """Steps towards ``target``, each from the last, until it arrives (the node) or is
    blocked (None)."""
    i = _extend(tree, target, world, p)
    while i is not None and not np.array_equal(tree.nodes[i], target):
        i = _step_from(tree, i, target, world, p)
    return i


def _sample(world: BaseWorld, rng: np.random.Generator) -> FloatArray:
    x, y = world.bounds.sample(rng)
    return np.array([x, y, rng.uniform(-np.pi, np.pi)])


def rrt_connect(
    start: FloatArray, goal: FloatArray, world: BaseWorld, rng: np.random.Generator, p: RRTParams
) -> list[FloatArray] | None:
    """A collision-free SE(2) polyline from ``start`` to ``goal``, or None."""
    if not world.free(np.vstack([start, goal])).all():
        return None
    if _edge_free(world, start, goal, p):
        return [start.copy(), goal.copy()]
    trees = (_Tree(start), _Tree(goal))
    for it in range(p.max_iterations):
        grow, other = trees[it % 2], trees[1 - it % 2]
        target = other.nodes[0].copy() if rng.random() < p.goal_bias else _sample(world, rng)
        i = _extend(grow, target, world, p)
        if i is None:
            continue
        j = _connect(other, grow.nodes[i], world, p)
        if j is not None:
            i0, i1 = (i, j) if grow is trees[0] else (j, i)
            return trees[0].branch(i0)[::-1] + trees[1].branch(i1)[1:]
    return None


def shortcut(
    path: list[FloatArray], world: BaseWorld, rng: np.random.Generator, p: RRTParams
) -> list[FloatArray]:
    """Replace random stretches of ``path`` by straight segments where those are free."""
    pts = list(path)
    for _ in range(p.shortcuts):
        if len(pts) <= 2:
            break
        i, j = sorted(int(k) for k in rng.choice(len(pts), size=2, replace=False))
        if j - i > 1 and _edge_free(world, pts[i], pts[j], p):
            pts = pts[: i + 1] + pts[j:]
    return pts


def plan_base_path(
    q1: BaseConf, q2: BaseConf, world: BaseWorld, rng: np.random.Generator, p: RRTParams
) -> BaseTraj | None:
    """RRT-Connect then shortcutting; None when no path was found."""
    path = rrt_connect(_array(q1), _array(q2), world, rng, p)
    if path is None:
        return None
    nodes = shortcut(path, world, rng, p)
    dense = [nodes[0]]
    for a, b in itertools.pairwise(nodes):
        legs = edge_waypoints(a, b, world, p)
        if legs is None:  # cannot happen: every edge kept was checked
            return None
        dense += [q for q in legs if not np.allclose(q, dense[-1])]
    confs = [BaseConf(float(x), float(y), wrap_angle(float(t))) for x, y, t in dense]
    confs[0], confs[-1] = q1, q2
    return BaseTraj(tuple(confs))


def _array(q: BaseConf) -> FloatArray:
    return np.array([q.x, q.y, q.theta], dtype=float)


def traj_free(traj: BaseTraj, world: BaseWorld, p: RRTParams) -> bool:
    """Every straight SE(2) segment between consecutive waypoints of ``traj`` is free."""
    qs = [_array(q) for q in traj.path]
    return all(
        world.segment_free(a, b, p.resolution, p.angular_resolution)
        for a, b in itertools.pairwise(qs)
    )


def drivable(traj: BaseTraj, tol: float = 1e-6) -> bool:
    """Each segment is a turn in place or a straight drive along (or against) the heading."""
    for a, b in itertools.pairwise(traj.path):
        d = np.hypot(b.x - a.x, b.y - a.y)
        if d < tol:
            continue
        h = np.arctan2(b.y - a.y, b.x - a.x)
        same = abs(wrap_angle(b.theta - a.theta)) < tol
        along = min(abs(wrap_angle(h - a.theta)), abs(wrap_angle(h - a.theta + np.pi))) < tol
        if not (same and along):
            return False
    return True
