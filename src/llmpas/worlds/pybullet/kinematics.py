"""Panda kinematics and collision checks in a :class:`~llmpas.worlds.pybullet.scene.Scene`.

PyBullet's damped-least-squares IK can land far from the target (one call has been seen to miss
by 0.3 m), so every solution is verified by forward kinematics and re-seeded from random
configurations until it is within tolerance. Collision checks use ``getClosestPoints`` against the
world bodies, filter the Panda-Husky mount contact, and test a fixed list of Panda self-collision
link pairs (pairs that touch in the folded home configuration are disabled).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from llmpas.worlds.pybullet.pybullet_values import Vector
from llmpas.worlds.pybullet.scene import ARM_JOINTS, EE_LINK, HOME_CONF, Scene

log = logging.getLogger(__name__)

Conf = tuple[float, ...]
MOUNT_LINKS = frozenset({-1, 0})  # Panda links that legitimately touch the Husky
HAND_GROUP = frozenset({7, 8, 9, 10, 11})  # rigidly attached: never checked against each other


@dataclass(frozen=True)
class Limits:
    lower: tuple[float, ...]
    upper: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.lower) != len(self.upper) or any(
            lo > hi for lo, hi in zip(self.lower, self.upper, strict=True)
        ):
            raise ValueError("joint limits must be paired and ordered")

    @property
    def ranges(self) -> tuple[float, ...]:
        return tuple(hi - lo for lo, hi in zip(self.lower, self.upper, strict=True))

    def sample(self, rng: np.random.Generator) -> Conf:
        return tuple(float(v) for v in rng.uniform(self.lower, self.upper))

    def clip(self, q: Sequence[float]) -> Conf:
        return tuple(float(v) for v in np.clip(q, self.lower, self.upper))

    def contains(self, q: Sequence[float], tol: float = 1e-6) -> bool:
        return all(
            lo - tol <= v <= hi + tol for v, lo, hi in zip(q, self.lower, self.upper, strict=True)
        )


def arm_limits(scene: Scene) -> Limits:
    lo, hi = [], []
    for j in ARM_JOINTS:
        info = p.getJointInfo(scene.panda, j, physicsClientId=scene.client)
        lo.append(float(info[8]))
        hi.append(float(info[9]))
    return Limits(tuple(lo), tuple(hi))


@contextlib.contextmanager
def preserved(scene: Scene) -> Iterator[None]:
    """Restore the base pose and arm configuration after a planning computation."""
    base, arm = scene.base_pose(), scene.arm_conf()
    try:
        yield
    finally:
        scene.set_base(*base)
        scene.set_arm(arm, hold=False)


def top_grasp_orientation(yaw: float = 0.0) -> tuple[float, float, float, float]:
    """Gripper pointing down, fingers closing across ``yaw``."""
    return tuple(p.getQuaternionFromEuler([math.pi, 0.0, yaw]))


def forward_grasp_orientation(heading: float) -> tuple[float, float, float, float]:
    """Gripper pointing horizontally along ``heading`` (fingers closing horizontally)."""
    return tuple(p.getQuaternionFromEuler([0.0, math.pi / 2, heading]))


def quat_angle(a: Vector, b: Vector) -> float:
    d = abs(float(np.dot(np.asarray(a), np.asarray(b))))
    return 2.0 * math.acos(min(1.0, d))


@dataclass(frozen=True)
class IKConfig:
    attempts: int = 12  # seeds: the current configuration, then random ones
    refinements: int = 4  # IK calls per seed, each starting from the previous answer
    pos_tol: float = 5e-3  # metres
    orn_tol: float = 0.05  # radians
    iterations: int = 100

    def __post_init__(self) -> None:
        if self.attempts < 1 or self.refinements < 1 or self.iterations < 1:
            raise ValueError("IK attempts, refinements and iterations must be >= 1")
        if self.pos_tol <= 0 or self.orn_tol <= 0:
            raise ValueError("IK tolerances must be positive")


def forward(scene: Scene, q: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """End-effector pose at ``q`` (the arm is left at ``q``)."""
    scene.set_arm(q, hold=False)
    return scene.ee_pose()


def solve_ik(
    scene: Scene,
    pos: Vector,
    orn: Vector,
    rng: np.random.Generator,
    config: IKConfig | None = None,
    seed: Sequence[float] | None = None,
    valid: Collision | None = None,
) -> Conf | None:
    """An arm configuration that puts the grasp frame at (``pos``, ``orn``), verified by FK
    (and collision-free when ``valid`` is given), or None. The arm is restored afterwards."""
    cfg = config or IKConfig()
    limits = arm_limits(scene)
    target = np.asarray(pos, dtype=float)
    with preserved(scene):
        seeds = itertools.chain(
            [tuple(seed) if seed is not None else scene.arm_conf(), HOME_CONF],
            (limits.sample(rng) for _ in range(cfg.attempts)),
        )
        for start in itertools.islice(seeds, cfg.attempts):
            q = limits.clip(start)
            for _ in range(cfg.refinements):
                scene.set_arm(q, hold=False)
                sol = p.calculateInverseKinematics(
                    scene.panda,
                    EE_LINK,
                    list(target),
                    list(orn),
                    lowerLimits=list(limits.lower),
                    upperLimits=list(limits.upper),
                    jointRanges=list(limits.ranges),
                    restPoses=list(q),
                    maxNumIterations=cfg.iterations,
                    residualThreshold=1e-5,
                    physicsClientId=scene.client,
                )
                q = limits.clip(sol[: len(ARM_JOINTS)])
                at, rot = forward(scene, q)
                if (
                    np.linalg.norm(at - target) <= cfg.pos_tol
                    and quat_angle(rot, orn) <= cfg.orn_tol
                ):
                    if valid is None or not valid.collides(q):
                        return q
                    break  # in collision: try another seed
    return None


# --------------------------------------------------------------------------- collisions


def _panda_links(scene: Scene) -> list[int]:
    return list(range(-1, p.getNumJoints(scene.panda, physicsClientId=scene.client)))


def _touching(scene: Scene, a: int, b: int, margin: float) -> bool:
    pts = p.getClosestPoints(scene.panda, scene.panda, margin, a, b, physicsClientId=scene.client)
    return bool(pts)


def self_collision_pairs(scene: Scene, margin: float = 0.0) -> tuple[tuple[int, int], ...]:
    """Panda link pairs worth checking: not adjacent, not both in the hand, not touching in the
    home or zero configuration (those are structural contacts)."""
    links = _panda_links(scene)
    pairs = [
        (a, b)
        for a, b in itertools.combinations(links, 2)
        if b - a > 1 and not (a in HAND_GROUP and b in HAND_GROUP)
    ]
    with preserved(scene):
        disabled = set()
        for q in (HOME_CONF, (0.0,) * len(ARM_JOINTS)):
            scene.set_arm(q, hold=False)
            disabled |= {pr for pr in pairs if _touching(scene, *pr, margin)}
    return tuple(pr for pr in pairs if pr not in disabled)


class Collision:
    """Collision checks of the arm (and what it holds) against the world and itself."""

    def __init__(
        self,
        scene: Scene,
        obstacles: Iterable[str] | None = None,
        attached: str | None = None,
        margin: float = 0.005,
    ) -> None:
        self.scene = scene
        self.margin = margin
        self.attached = attached
        names = list(scene.bodies) if obstacles is None else list(obstacles)
        self.obstacles = [
            scene.bodies[n] for n in names if n not in ("panda", attached) and n in scene.bodies
        ]
        self.pairs = self_collision_pairs(scene)
        self.checks = 0

    def collides(self, q: Sequence[float] | None = None) -> bool:
        """Whether the arm at ``q`` (default: as it is) is in collision. Leaves the arm at q."""
        s, c = self.scene, self.scene.client
        self.checks += 1
        if q is not None:
            s.set_arm(q, hold=False)
        for b in self.obstacles:
            for pt in p.getClosestPoints(s.panda, b, self.margin, physicsClientId=c):
                if b == s.husky and pt[3] in MOUNT_LINKS:
                    continue
                return True
        for a, b in self.pairs:
            if p.getClosestPoints(s.panda, s.panda, 0.0, a, b, physicsClientId=c):
                return True
        if self.attached is not None:
            held = s.bodies[self.attached]
            s.carry()
            for b in self.obstacles:
                if p.getClosestPoints(held, b, 0.0, physicsClientId=c):
                    return True
        return False

    def details(self, q: Sequence[float]) -> list[str]:
        """What collides at ``q`` (for diagnostics and tests)."""
        s, c = self.scene, self.scene.client
        s.set_arm(q, hold=False)
        out = []
        for b in self.obstacles:
            for pt in p.getClosestPoints(s.panda, b, self.margin, physicsClientId=c):
                if b == s.husky and pt[3] in MOUNT_LINKS:
                    continue
                out.append(f"panda link {pt[3]} - {s.names[b]}")
        for a, b in self.pairs:
            if p.getClosestPoints(s.panda, s.panda, 0.0, a, b, physicsClientId=c):
                out.append(f"self {a}-{b}")
        return out
