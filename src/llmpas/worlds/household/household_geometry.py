"""Plane geometry of the household: collisions of the base with furniture, reach, base poses."""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Iterator

import numpy as np

from llmpas.worlds.household.household_values import BaseConf, Motion
from llmpas.worlds.household.layout import Layout, Rect


def rect_distance(x: float, y: float, rect: Rect) -> float:
    """Distance from a point to a rectangle (0 inside)."""
    x0, y0, x1, y1 = rect
    dx = max(x0 - x, 0.0, x - x1)
    dy = max(y0 - y, 0.0, y - y1)
    return math.hypot(dx, dy)


def base_free(layout: Layout, x: float, y: float, clearance: float = 0.0) -> bool:
    """The round base at (x, y) stays on the floor and clear of every piece of furniture."""
    r = layout.robot_radius + clearance
    w, h = layout.size
    if not (r <= x <= w - r and r <= y <= h - r):
        return False
    return all(rect_distance(x, y, f.rect) >= r for f in layout.solid())


CLEARANCE = 0.05  # m kept free around the base, beyond its radius, for odometry errors


def blocking(
    layout: Layout, a: BaseConf, b: BaseConf, step: float = 0.05, clearance: float = CLEARANCE
) -> str | None:
    """The furniture the straight drive a -> b runs into, or None when the drive is free."""
    n = max(1, math.ceil(a.distance(b) / step))
    for i in range(n + 1):
        t = i / n
        x, y = a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)
        for f in layout.solid():
            if rect_distance(x, y, f.rect) < layout.robot_radius + clearance:
                return f.name
        w, h = layout.size
        if not (0 <= x <= w and 0 <= y <= h):
            return "the wall"
    return None


def facing(x: float, y: float, tx: float, ty: float) -> BaseConf:
    return BaseConf(round(x, 3), round(y, 3), round(math.atan2(ty - y, tx - x), 3))


def base_poses_near(
    layout: Layout, tx: float, ty: float, rng: np.random.Generator, reach: float | None = None
) -> Iterator[BaseConf]:
    """Collision-free base poses facing (tx, ty) and within reach of it; the first ones are the
    closest to the open middle of the room, later ones random."""
    reach = layout.reach if reach is None else reach
    cx, cy = layout.size[0] / 2, layout.size[1] / 2
    toward = math.atan2(cy - ty, cx - tx)
    offsets = [0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5]
    candidates = [(toward + o, 0.8 * reach) for o in offsets]
    while True:
        if candidates:
            ang, d = candidates.pop(0)
        else:
            ang, d = rng.uniform(-math.pi, math.pi), rng.uniform(0.5 * reach, 0.95 * reach)
        x, y = tx + d * math.cos(ang), ty + d * math.sin(ang)
        if base_free(layout, x, y, CLEARANCE):
            yield facing(x, y, tx, ty)


def drive(layout: Layout, a: BaseConf, b: BaseConf) -> Motion | None:
    """A collision-free drive a -> b: straight when free, else a shortest path on a 10 cm grid
    (A*), shortcut to a few way points. None when b cannot be reached."""
    if blocking(layout, a, b) is None:
        return Motion((a, b))
    cells = _grid_path(layout, (a.x, a.y), (b.x, b.y))
    if cells is None:
        return None
    points = _shortcut(layout, [(a.x, a.y), *cells[1:-1], (b.x, b.y)])
    way = [a]
    for (x, y), (nx, ny) in itertools.pairwise(points[1:]):
        way.append(BaseConf(round(x, 3), round(y, 3), round(math.atan2(ny - y, nx - x), 3)))
    way.append(b)
    return Motion(tuple(way))


GRID = 0.1


def _cell(p: tuple[float, float]) -> tuple[int, int]:
    return round(p[0] / GRID), round(p[1] / GRID)


def _grid_path(
    layout: Layout, start: tuple[float, float], goal: tuple[float, float]
) -> list[tuple[float, float]] | None:
    s, g = _cell(start), _cell(goal)
    w, h = (round(v / GRID) for v in layout.size)
    free: dict[tuple[int, int], bool] = {}

    def ok(c: tuple[int, int]) -> bool:
        if c in (s, g):
            return True
        if c not in free:
            free[c] = (
                0 <= c[0] <= w
                and 0 <= c[1] <= h
                and base_free(layout, c[0] * GRID, c[1] * GRID, CLEARANCE)
            )
        return free[c]

    moves = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    frontier: list[tuple[float, tuple[int, int]]] = [(0.0, s)]
    cost = {s: 0.0}
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    while frontier:
        _, c = heapq.heappop(frontier)
        if c == g:
            path = [c]
            while path[-1] in parent:
                path.append(parent[path[-1]])
            return [(x * GRID, y * GRID) for x, y in reversed(path)]
        for dx, dy in moves:
            n = (c[0] + dx, c[1] + dy)
            step = math.hypot(dx, dy)
            if ok(n) and cost[c] + step < cost.get(n, math.inf):
                cost[n] = cost[c] + step
                parent[n] = c
                heapq.heappush(frontier, (cost[n] + math.dist(n, g), n))
    return None


def _shortcut(layout: Layout, pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Greedy string pulling: from each kept point, jump to the farthest visible one."""
    out = [pts[0]]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1:
            a = BaseConf(pts[i][0], pts[i][1], 0.0)
            b = BaseConf(pts[j][0], pts[j][1], 0.0)
            if blocking(layout, a, b) is None:
                break
            j -= 1
        out.append(pts[j])
        i = j
    return out
