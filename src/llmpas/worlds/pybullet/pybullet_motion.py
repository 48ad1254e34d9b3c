"""Motion planning with OMPL: RRT-Connect for the Panda arm, an SE(2) planner for the Husky.

Both planners try the straight line first (cheap and usually enough in an open room) and fall
back to OMPL's RRT-Connect, then simplify and interpolate the path. The arm planner checks
configurations in the PyBullet scene (:class:`~llmpas.worlds.pybullet.kinematics.Collision`); the
base planner checks a two-circle footprint of the Husky against the tables' rectangles (pure
geometry: the arm is carried folded above the base while driving).
"""

from __future__ import annotations

import itertools
import logging
import math
import zlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from llmpas.worlds.pybullet.kinematics import Collision, Conf, arm_limits, preserved
from llmpas.worlds.pybullet.scene import Rect, Scene

log = logging.getLogger(__name__)

Pose2 = tuple[float, float, float]


def _ompl() -> tuple[object, object]:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_ERROR)  # OMPL logs to C stdout; keep only errors
    return ob, og


def _seed_ompl(seed: int) -> None:
    """Seed OMPL's random numbers. OMPL seeds itself from the clock once per process, so an
    unseeded RRT-Connect draws other paths in every run (and, once in a while, a path that fails
    where it passed before: a different anomaly report, a different prompt). The planners and
    samplers built after this call draw from ``seed``; OMPL warns that the generator had already
    started, which is harmless here (nothing built before is reused), so it is silenced."""
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    try:
        ou.RNG.setSeed(seed)
    finally:
        ou.setLogLevel(ou.LOG_ERROR)


def motion_seed(seed: int, start: Sequence[float], goal: Sequence[float]) -> int:
    """A seed for one query: the config's seed and the query's end points (rounded), so the same
    query plans the same path whatever ran before it in the process."""
    text = repr((seed, [round(float(x), 6) for x in (*start, *goal)]))
    return zlib.crc32(text.encode()) or 1  # OMPL takes 0 as "no seed"


def wrap(a: float) -> float:
    """An angle in [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


@dataclass(frozen=True)
class MotionConfig:
    timeout: float = 3.0  # seconds for RRT-Connect
    seed: int = 0  # OMPL's random numbers, with each query's end points (motion_seed)
    resolution: float = 0.05  # max joint step (rad) or base step (m) between checked states

    def __post_init__(self) -> None:
        if self.timeout <= 0:
            raise ValueError("timeout must be positive")
        if not 0 < self.resolution <= 0.5:
            raise ValueError(f"resolution {self.resolution} out of (0, 0.5]")


def interpolate(a: Sequence[float], b: Sequence[float], step: float) -> list[Conf]:
    """States from ``a`` to ``b`` (inclusive), at most ``step`` apart in any coordinate."""
    va, vb = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = max(1, math.ceil(float(np.max(np.abs(vb - va))) / step))
    return [tuple(float(x) for x in va + (vb - va) * k / n) for k in range(n + 1)]


def _densify(path: Sequence[Conf], step: float) -> list[Conf]:
    out: list[Conf] = [tuple(path[0])]
    for a, b in itertools.pairwise(path):
        out.extend(interpolate(a, b, step)[1:])
    return out


def _solve(
    space: object,
    valid: Callable[[Sequence[float]], bool],
    start: Sequence[float],
    goal: Sequence[float],
    read: Callable[[object], tuple[float, ...]],
    write: Callable[[object, Sequence[float]], None],
    config: MotionConfig,
    resolution: float,
) -> list[Conf] | None:
    _ob, og = _ompl()
    _seed_ompl(motion_seed(config.seed, start, goal))
    ss = og.SimpleSetup(space)  # type: ignore[attr-defined]
    ss.setStateValidityChecker(lambda s: bool(valid(read(s))))
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(resolution)
    s0, s1 = space.allocState(), space.allocState()  # type: ignore[attr-defined]
    write(s0, start)
    write(s1, goal)
    ss.setStartAndGoalStates(s0, s1)
    ss.setPlanner(og.RRTConnect(si))  # type: ignore[attr-defined]
    solved = ss.solve(config.timeout)
    if not solved or not ss.haveExactSolutionPath():
        return None
    states = [read(s) for s in ss.getSolutionPath().getStates()]
    return shortcut(states, valid, step=config.resolution)


def shortcut(
    path: Sequence[Sequence[float]], valid: Callable[[Sequence[float]], bool], step: float
) -> list[Conf]:
    """Greedy shortcutting: from each kept state jump to the farthest state reachable in a
    straight (checked) line."""
    pts = [tuple(float(x) for x in q) for q in path]
    out = [pts[0]]
    i = 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not all(valid(q) for q in interpolate(pts[i], pts[j], step)):
            j -= 1
        out.append(pts[j])
        i = j
    return out


# --------------------------------------------------------------------------- the arm


def plan_arm(
    scene: Scene,
    start: Sequence[float],
    goal: Sequence[float],
    collision: Collision,
    config: MotionConfig | None = None,
) -> list[Conf] | None:
    """A collision-free joint path from ``start`` to ``goal`` (dense: steps <= resolution), or
    None. The arm is restored afterwards."""
    cfg = config or MotionConfig()
    limits = arm_limits(scene)
    with preserved(scene):
        if collision.collides(start) or collision.collides(goal):
            return None
        line = interpolate(start, goal, cfg.resolution)
        if not any(collision.collides(q) for q in line):
            return line
        ob, _ = _ompl()
        space = ob.RealVectorStateSpace(7)  # type: ignore[attr-defined]
        bounds = ob.RealVectorBounds(7)  # type: ignore[attr-defined]
        for i, (lo, hi) in enumerate(zip(limits.lower, limits.upper, strict=True)):
            bounds.setLow(i, lo)
            bounds.setHigh(i, hi)
        space.setBounds(bounds)
        extent = math.sqrt(sum(r * r for r in limits.ranges))

        def read(s: object) -> tuple[float, ...]:
            return tuple(float(s[i]) for i in range(7))  # type: ignore[index]

        def write(s: object, q: Sequence[float]) -> None:
            for i, v in enumerate(q):
                s[i] = float(v)  # type: ignore[index]

        path = _solve(
            space,
            lambda q: not collision.collides(q),
            start,
            goal,
            read,
            write,
            cfg,
            cfg.resolution / extent,
        )
        if path is None:
            return None
        dense = _densify(path, cfg.resolution)
        if any(collision.collides(q) for q in dense):  # OMPL's resolution is a fraction
            log.debug("arm path collides after densifying; rejected")
            return None
        return dense


# --------------------------------------------------------------------------- the base


@dataclass(frozen=True)
class Footprint:
    """The Husky as two discs on its axis (the folded arm stays inside)."""

    radius: float = 0.3
    offset: float = 0.2  # disc centres at +-offset along the heading

    def __post_init__(self) -> None:
        if self.radius <= 0 or self.offset < 0:
            raise ValueError("footprint radius must be positive and offset non-negative")

    def discs(self, q: Pose2) -> list[tuple[float, float]]:
        x, y, t = q
        c, s = math.cos(t), math.sin(t)
        return [(x + k * self.offset * c, y + k * self.offset * s) for k in (1, -1)]


class BaseChecker:
    """Whether a base pose is free: footprint discs clear of the obstacle rectangles and inside
    the room."""

    def __init__(
        self, obstacles: Iterable[Rect], room: Rect, footprint: Footprint | None = None
    ) -> None:
        self.obstacles = tuple(obstacles)
        self.room = room
        self.footprint = footprint or Footprint()

    @classmethod
    def of(cls, scene: Scene, margin: float = 2.0) -> BaseChecker:
        rects = list(scene.tables.values())
        b = scene.base_pose()
        x0 = min([r.x0 for r in rects] + [b[0]]) - margin
        y0 = min([r.y0 for r in rects] + [b[1]]) - margin
        x1 = max([r.x1 for r in rects] + [b[0]]) + margin
        y1 = max([r.y1 for r in rects] + [b[1]]) + margin
        return cls(rects, Rect(x0, y0, x1, y1))

    def clearance(self, q: Pose2) -> float:
        r = self.footprint.radius
        gaps = [
            rect.distance(cx, cy) - r
            for cx, cy in self.footprint.discs(q)
            for rect in self.obstacles
        ]
        return min(gaps) if gaps else math.inf

    def free(self, q: Pose2) -> bool:
        x, y, _ = q
        return self.room.contains(x, y, self.footprint.radius + self.footprint.offset) and (
            self.clearance(q) >= 0.0
        )


def _angle_step(a: float, b: float) -> float:
    return (b - a + math.pi) % (2 * math.pi) - math.pi


def base_line(a: Pose2, b: Pose2, step: float) -> list[Pose2]:
    """Turn towards the goal, drive straight, turn to the goal heading (a differential drive)."""
    dist = math.hypot(b[0] - a[0], b[1] - a[1])
    out: list[Pose2] = [a]
    if dist > 1e-6:
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        # drive backwards when that needs less turning
        if abs(_angle_step(a[2], heading)) > math.pi / 2:
            heading = heading + math.pi
        out += _turn(a, heading, step)
        n = max(1, math.ceil(dist / step))
        for k in range(1, n + 1):
            out.append((a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n, out[-1][2]))
    out += _turn(out[-1], b[2], step)
    return out


def _turn(q: Pose2, yaw: float, step: float) -> list[Pose2]:
    d = _angle_step(q[2], yaw)
    n = math.ceil(abs(d) / (2 * step)) if abs(d) > 1e-9 else 0
    return [(q[0], q[1], q[2] + d * k / n) for k in range(1, n + 1)]


def plan_base(
    checker: BaseChecker, start: Pose2, goal: Pose2, config: MotionConfig | None = None
) -> list[Pose2] | None:
    """A collision-free base path (turn-drive-turn pieces), or None."""
    cfg = config or MotionConfig()
    start, goal = (start[0], start[1], wrap(start[2])), (goal[0], goal[1], wrap(goal[2]))
    if not checker.free(goal):
        return None
    line = base_line(start, goal, cfg.resolution)
    if all(checker.free(q) for q in line[1:]):
        return line
    via = grid_plan(checker, start, goal, cfg.resolution)
    if via is not None:
        return via
    return ompl_base_plan(checker, start, goal, cfg)


def _swept_free(checker: BaseChecker, x: float, y: float) -> bool:
    """Free for every heading: the disc swept by the footprint turning in place is clear."""
    f = checker.footprint
    reach = f.radius + f.offset
    if not checker.room.contains(x, y, reach):
        return False
    return all(rect.distance(x, y) >= reach for rect in checker.obstacles)


def grid_plan(
    checker: BaseChecker, start: Pose2, goal: Pose2, step: float, cell: float = 0.05
) -> list[Pose2] | None:
    """A deterministic detour: A* over a grid of positions where the base can turn freely,
    shortcut by line of sight, then driven as turn-drive-turn pieces (each checked with the
    exact footprint)."""
    room = checker.room
    nx = int((room.x1 - room.x0) / cell) + 1
    ny = int((room.y1 - room.y0) / cell) + 1

    def centre(c: tuple[int, int]) -> tuple[float, float]:
        return (room.x0 + c[0] * cell, room.y0 + c[1] * cell)

    def snap(x: float, y: float) -> tuple[int, int]:
        return (round((x - room.x0) / cell), round((y - room.y0) / cell))

    free_cache: dict[tuple[int, int], bool] = {}

    def free(c: tuple[int, int]) -> bool:
        if c not in free_cache:
            inside = 0 <= c[0] < nx and 0 <= c[1] < ny
            free_cache[c] = inside and _swept_free(checker, *centre(c))
        return free_cache[c]

    def nearest_free(x: float, y: float) -> tuple[int, int] | None:
        c0 = snap(x, y)
        for r in range(0, 6):
            ring = [
                (c0[0] + i, c0[1] + j)
                for i in range(-r, r + 1)
                for j in range(-r, r + 1)
                if max(abs(i), abs(j)) == r and free((c0[0] + i, c0[1] + j))
            ]
            if ring:
                return min(ring, key=lambda c: math.dist(centre(c), (x, y)))
        return None

    a, b = nearest_free(start[0], start[1]), nearest_free(goal[0], goal[1])
    if a is None or b is None:
        return None
    cells = _astar(a, b, free)
    if cells is None:
        return None
    points = [centre(c) for c in cells]

    # line-of-sight shortcut on the swept-free grid
    def visible(p: tuple[float, float], q: tuple[float, float]) -> bool:
        n = max(1, math.ceil(math.dist(p, q) / (cell / 2)))
        return all(
            _swept_free(checker, p[0] + (q[0] - p[0]) * k / n, p[1] + (q[1] - p[1]) * k / n)
            for k in range(n + 1)
        )

    kept = [points[0]]
    i = 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not visible(points[i], points[j]):
            j -= 1
        kept.append(points[j])
        i = j
    out: list[Pose2] = [start]
    for x, y in kept:
        out += base_line(out[-1], (x, y, out[-1][2]), step)[1:]
    out += base_line(out[-1], goal, step)[1:]
    if not all(checker.free(q) for q in out[1:]):
        return None
    return out


def _astar(
    a: tuple[int, int], b: tuple[int, int], free: Callable[[tuple[int, int]], bool]
) -> list[tuple[int, int]] | None:
    import heapq

    moves = [(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0)]
    best = {a: 0.0}
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    frontier = [(math.dist(a, b), 0.0, a)]
    while frontier:
        _, g, c = heapq.heappop(frontier)
        if c == b:
            path = [c]
            while c in parent:
                c = parent[c]
                path.append(c)
            return path[::-1]
        if g > best.get(c, math.inf):
            continue
        for i, j in moves:
            n = (c[0] + i, c[1] + j)
            cost = g + math.hypot(i, j)
            if cost < best.get(n, math.inf) and free(n):
                best[n] = cost
                parent[n] = c
                heapq.heappush(frontier, (cost + math.dist(n, b), cost, n))
    return None


def ompl_base_plan(
    checker: BaseChecker, start: Pose2, goal: Pose2, cfg: MotionConfig
) -> list[Pose2] | None:
    """SE(2) RRT-Connect (a last resort: its random seed is OMPL's own)."""
    ob, _ = _ompl()
    space = ob.SE2StateSpace()  # type: ignore[attr-defined]
    bounds = ob.RealVectorBounds(2)  # type: ignore[attr-defined]
    r = checker.room
    bounds.setLow(0, r.x0)
    bounds.setHigh(0, r.x1)
    bounds.setLow(1, r.y0)
    bounds.setHigh(1, r.y1)
    space.setBounds(bounds)

    def read(s: object) -> tuple[float, ...]:
        return (float(s.getX()), float(s.getY()), float(s.getYaw()))  # type: ignore[attr-defined]

    def write(s: object, q: Sequence[float]) -> None:
        s.setX(float(q[0]))  # type: ignore[attr-defined]
        s.setY(float(q[1]))  # type: ignore[attr-defined]
        s.setYaw(float(q[2]))  # type: ignore[attr-defined]

    extent = math.hypot(r.x1 - r.x0, r.y1 - r.y0)
    start_ok = start if checker.free(start) else None
    if start_ok is None:
        return None
    path = _solve(
        space,
        lambda q: checker.free((q[0], q[1], q[2])),
        start,
        goal,
        read,
        write,
        cfg,
        cfg.resolution / extent,
    )
    if path is None:
        return None
    out: list[Pose2] = [start]
    for q in path[1:]:
        piece = base_line(out[-1], (q[0], q[1], q[2]), cfg.resolution)[1:]
        out += piece
    if not all(checker.free(q) for q in out[1:]):
        # turning in place between OMPL states may clip a table: keep OMPL's own headings
        out = [start]
        for q in path[1:]:
            d = _angle_step(out[-1][2], q[2])
            for x, y, t in interpolate(out[-1], (q[0], q[1], out[-1][2] + d), cfg.resolution)[1:]:
                out.append((x, y, wrap(t)))
        if not all(checker.free(q) for q in out):
            return None
    return out


def path_length(path: Sequence[Pose2]) -> float:
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(path))
