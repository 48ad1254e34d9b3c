"""Stream implementations for the household domain (``household/stream.pddl``) on the PyBullet
world, with real geometry: placements on table tops and in bowls, top/forward grasps, base poses
from which PyBullet IK (verified by FK, collision-checked against the static scene) reaches the
object, base poses facing a table, and OMPL SE(2) drives.

The streams run on the robot's model of the static world (tables, its own body), never on the
true poses of movable objects: those come from the belief (``locate``).
``inverse-kinematics``, ``sample-view`` and ``plan-base-motion`` are deferred by default.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass

import numpy as np

from llmpas.language.bindings import Implementation, cost, function, sampler, test
from llmpas.worlds.pybullet.kinematics import Collision, IKConfig, preserved, solve_ik
from llmpas.worlds.pybullet.pybullet_motion import BaseChecker, plan_base
from llmpas.worlds.pybullet.pybullet_values import BaseConf, BasePath, Grasp, ObjectPose
from llmpas.worlds.pybullet.scene import TABLE_TOP, Rect, Scene
from llmpas.worlds.pybullet.skills import approach_axis, grasp_orientation

DEFAULT_DEFERRED = ("inverse-kinematics", "sample-view", "plan-base-motion")

Locator = Callable[[str], ObjectPose | None]  # where an object is believed to be


@dataclass(frozen=True)
class StreamConfig:
    standoff: tuple[float, float] = (0.5, 0.62)  # base centre to table edge (m)
    lateral: float = 0.15  # sideways spread of base samples around the target (m)
    edge_margin: float = 0.1  # placements keep this far from a table's edge
    reach_band: float = 0.3  # ... and at most this far in (reachable from the edge)
    kin_samples: int = 6
    view_samples: int = 6
    pre_distance: float = 0.12

    def __post_init__(self) -> None:
        lo, hi = self.standoff
        if not 0 < lo <= hi:
            raise ValueError("standoff must be 0 < low <= high")
        if self.lateral < 0 or self.edge_margin < 0 or self.reach_band <= self.edge_margin:
            raise ValueError("need lateral >= 0 and reach_band > edge_margin >= 0")
        if self.kin_samples < 1 or self.view_samples < 1:
            raise ValueError("sample counts must be >= 1")


def _sides(rect: Rect, x: float, y: float) -> list[tuple[float, str]]:
    """The table's sides ordered by the distance of (x, y) to them."""
    d = {"-x": x - rect.x0, "+x": rect.x1 - x, "-y": y - rect.y0, "+y": rect.y1 - y}
    return sorted((v, k) for k, v in d.items())


def base_facing(
    rect: Rect, side: str, along: float, standoff: float, yaw_jitter: float = 0.0
) -> BaseConf:
    """A base pose in front of ``side`` of the table, at ``along`` on that side, facing it."""
    if side == "-x":
        return BaseConf(rect.x0 - standoff, along, 0.0 + yaw_jitter)
    if side == "+x":
        return BaseConf(rect.x1 + standoff, along, math.pi + yaw_jitter)
    if side == "-y":
        return BaseConf(along, rect.y0 - standoff, math.pi / 2 + yaw_jitter)
    return BaseConf(along, rect.y1 + standoff, -math.pi / 2 + yaw_jitter)


class Geometry:
    """The robot's planning model: the static scene, a base checker and IK."""

    def __init__(
        self, scene: Scene, rng: np.random.Generator, config: StreamConfig | None = None
    ) -> None:
        self.scene = scene
        self.rng = rng
        self.config = config or StreamConfig()
        self.checker = BaseChecker.of(scene)
        static = [n for n in scene.bodies if n not in scene.movable()]
        self.collision = Collision(scene, static)
        self.ik = IKConfig(attempts=6)

    def table_of(self, pose: ObjectPose) -> str | None:
        for name, rect in self.scene.tables.items():
            if rect.contains(pose.x, pose.y):
                return name
        return None

    def placements(self, obj: str, table: str) -> Iterator[ObjectPose]:
        cfg = self.config
        rect = self.scene.tables[table]
        o = self.scene.config.obj(obj)
        z = TABLE_TOP + o.origin_height
        while True:
            x = self.rng.uniform(rect.x0 + cfg.edge_margin, rect.x1 - cfg.edge_margin)
            y = self.rng.uniform(rect.y0 + cfg.edge_margin, rect.y1 - cfg.edge_margin)
            if _sides(rect, x, y)[0][0] <= cfg.reach_band:
                yield ObjectPose(table, round(float(x), 3), round(float(y), 3), z)

    def reaches(self, base: BaseConf, pose: ObjectPose, grasp: Grasp, height: float) -> bool:
        """Whether the arm, from ``base``, reaches the pre-grasp and the grasp (IK + FK, no
        collision with the static scene)."""
        if not self.checker.free(base.pose):
            return False
        heading = math.atan2(pose.y - base.y, pose.x - base.x)
        if grasp.kind == "top":
            point = np.array([pose.x, pose.y, pose.z + height / 2 - 0.015])
        else:
            point = np.array([pose.x, pose.y, pose.z + 0.005])
        orn = grasp_orientation(grasp.kind, heading)
        pre = point - approach_axis(grasp.kind, heading) * self.config.pre_distance
        with preserved(self.scene):
            self.scene.set_base(*base.pose)
            q = solve_ik(self.scene, pre, orn, self.rng, self.ik, valid=self.collision)
            if q is None:
                return False
            return solve_ik(self.scene, point, orn, self.rng, self.ik, seed=q) is not None

    def kin(self, obj: str, pose: ObjectPose, grasp: Grasp) -> Iterator[BaseConf]:
        cfg = self.config
        table = self.table_of(pose)
        if table is None:
            return
        rect = self.scene.tables[table]
        height = self.scene.config.obj(obj).height
        sides = [s for d, s in _sides(rect, pose.x, pose.y) if d <= 0.45]
        for _ in range(cfg.kin_samples * 4):
            if not sides:
                return
            side = sides[int(self.rng.integers(len(sides)))]
            along = pose.y if side in ("-x", "+x") else pose.x
            base = base_facing(
                rect,
                side,
                float(along + self.rng.uniform(-cfg.lateral, cfg.lateral)),
                float(self.rng.uniform(*cfg.standoff)),
            )
            base = BaseConf(round(base.x, 3), round(base.y, 3), round(base.theta, 3))
            if self.reaches(base, pose, grasp, height):
                yield base

    def views(self, table: str, near: tuple[float, float] | None) -> Iterator[BaseConf]:
        """Base poses facing the table, nearest side first (to ``near``, e.g. the robot)."""
        cfg = self.config
        rect = self.scene.tables[table]
        cx, cy = rect.center
        if near is None:
            sides = ["-x", "+x", "-y", "+y"]
        else:
            sides = sorted(
                ["-x", "+x", "-y", "+y"],
                key=lambda s: base_facing(rect, s, cy if "x" in s else cx, 0.6).distance(
                    BaseConf(near[0], near[1], 0.0)
                ),
            )
        for k in range(cfg.view_samples * 4):
            side = sides[k] if k < len(sides) else sides[0]
            centre = cy if side in ("-x", "+x") else cx
            along = centre + float(self.rng.uniform(-0.3, 0.3)) if k > 0 else centre
            base = base_facing(rect, side, along, float(self.rng.uniform(0.55, 0.7)))
            base = BaseConf(round(base.x, 3), round(base.y, 3), round(base.theta, 3))
            if self.checker.free(base.pose):
                yield base

    def drive(self, q1: BaseConf, q2: BaseConf) -> BasePath | None:
        path = plan_base(self.checker, q1.pose, q2.pose)
        return None if path is None else BasePath(tuple(path))


def make_streams(
    geometry: Geometry,
    locate: Locator,
    here: Callable[[], BaseConf | None],
    deferred: Collection[str] = DEFAULT_DEFERRED,
) -> dict[str, Implementation]:
    scene = geometry.scene
    bowls = {o.name for o in scene.config.objects if o.kind == "bowl"}

    def sample_pose(o: str, r: str) -> Iterator[tuple[ObjectPose]]:
        if r in bowls:
            at = locate(r)
            if at is not None:
                height = scene.config.obj(o).height
                yield (ObjectPose(r, at.x, at.y, TABLE_TOP + 0.01 + height / 2),)
            return
        if r not in scene.tables:
            return
        for p in geometry.placements(o, r):
            yield (p,)

    def sample_grasp(o: str) -> Iterator[tuple[Grasp]]:
        yield (Grasp("top"),)
        yield (Grasp("forward"),)

    def inverse_kinematics(o: str, p: ObjectPose, g: Grasp) -> Iterator[tuple[BaseConf]]:
        for q in geometry.kin(o, p, g):
            yield (q,)

    def sample_view(r: str) -> Iterator[tuple[BaseConf]]:
        table: str | None = r
        if r in bowls:
            at = locate(r)
            table = geometry.table_of(at) if at is not None else None
        if table is None or table not in scene.tables:
            return
        h = here()
        for q in geometry.views(table, None if h is None else (h.x, h.y)):
            yield (q,)

    def motion(q1: BaseConf, q2: BaseConf) -> tuple[BasePath] | None:
        path = geometry.drive(q1, q2)
        return None if path is None else (path,)

    def cfree(o: str, p: ObjectPose, o2: str, p2: ObjectPose) -> bool:
        if o == o2 or p.region != p2.region:
            return True
        a, b = scene.config.obj(o).size, scene.config.obj(o2).size
        return p.distance(p2) >= (a + b) / 2 * math.sqrt(2)

    def distance(q1: BaseConf, q2: BaseConf) -> float:
        return 1.0 + q1.distance(q2)

    return {
        "sample-pose": sampler(sample_pose, max_outputs=8),
        "sample-grasp": sampler(sample_grasp, max_outputs=1),
        "inverse-kinematics": sampler(
            inverse_kinematics, deferred="inverse-kinematics" in deferred
        ),
        "sample-view": sampler(sample_view, deferred="sample-view" in deferred),
        "plan-base-motion": function(motion, deferred="plan-base-motion" in deferred),
        "test-cfree": test(cfree),
        "distance": cost(distance),
    }
