"""The robot: a disc base and a planar three-link arm working in the vertical plane through
the base's heading. Inverse kinematics is analytic; the arm is checked against the furniture."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from llmpas.examples.mobile.mobile_geometry import Box, FloatArray, wrap_angle
from llmpas.examples.mobile.mobile_world import BaseConf, Grasp, JointConf, ObjectSpec, ObjPose

SHOULDER_HEIGHT = 1.0
SHOULDER_FORWARD = 0.2  # the shoulder sits this far ahead of the base centre
LINKS = (0.5, 0.5, 0.15)  # upper arm, forearm, hand (to the fingertips)
TUCKED: JointConf = (1.5, -2.9, 1.4)  # folded, the hand level at shoulder height
JOINT_LIMITS = ((-1.2, 2.0), (-3.0, 0.0), (-2.6, 2.6))
APPROACH = 0.12  # the gripper comes in from this far along the grasp direction
READY = (0.4, 0.15)  # hand (forward, above the pre-grasp) before it reaches out
CARTESIAN_STEP = 0.02  # spacing of IK solutions along straight hand motions
MAX_JUMP = 0.3  # largest joint change between neighbouring IK solutions (rad)
CLEARANCE = 0.02  # how close the arm may come to furniture
TOP_GAP = 0.02  # fingertips above the top of the object in a top grasp
STEP = 0.05  # largest joint change between trajectory points (rad)
POINTS_PER_LINK = 6


@dataclass(frozen=True)
class PlanarTarget:
    """Where the fingertips must be, in the arm's plane: forward ``r`` and up ``z`` from the
    shoulder, with the hand pointing at angle ``phi`` (0 forward, -pi/2 down)."""

    r: float
    z: float
    phi: float


def grasp_point(obj: ObjectSpec, pose: ObjPose, grasp: Grasp) -> tuple[float, float, float]:
    """The world point the fingertips reach for ``grasp`` of ``obj`` at ``pose``."""
    if grasp.kind == "top":
        return pose.x, pose.y, pose.z + obj.height + TOP_GAP
    return pose.x, pose.y, pose.z + obj.height / 2


def hand_angle(grasp: Grasp) -> float:
    return -np.pi / 2 if grasp.kind == "top" else 0.0


def facing(base_xy: FloatArray, point: tuple[float, float, float]) -> float:
    return float(np.arctan2(point[1] - base_xy[1], point[0] - base_xy[0]))


def planar_target(base: BaseConf, point: tuple[float, float, float], phi: float) -> PlanarTarget:
    """``point`` in the arm's plane; the base must face it."""
    r = float(np.hypot(point[0] - base.x, point[1] - base.y)) - SHOULDER_FORWARD
    return PlanarTarget(r, point[2] - SHOULDER_HEIGHT, phi)


def solve_ik(t: PlanarTarget) -> JointConf | None:
    """Elbow-up joint angles putting the fingertips at ``t``; None if out of reach or limits."""
    l1, l2, l3 = LINKS
    wr, wz = t.r - l3 * np.cos(t.phi), t.z - l3 * np.sin(t.phi)
    c2 = (wr * wr + wz * wz - l1 * l1 - l2 * l2) / (2 * l1 * l2)
    if abs(c2) > 1.0:
        return None
    q2 = -float(np.arccos(c2))
    q1 = float(np.arctan2(wz, wr) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2)))
    q3 = wrap_angle(t.phi - q1 - q2)
    q = (wrap_angle(q1), q2, q3)
    if any(not lo <= v <= hi for v, (lo, hi) in zip(q, JOINT_LIMITS, strict=True)):
        return None
    return q


def joint_points(q: JointConf) -> FloatArray:
    """``(4, 2)`` planar positions (forward, up) of shoulder, elbow, wrist and fingertips,
    relative to the shoulder."""
    return _joints(np.array([q], dtype=float))[0]


def _joints(path: FloatArray) -> FloatArray:
    """``(n, 4, 2)`` planar joint positions for the ``(n, 3)`` configurations of ``path``."""
    angles = np.cumsum(path, axis=1)
    steps = np.stack([np.cos(angles), np.sin(angles)], axis=2) * np.array(LINKS)[None, :, None]
    origin = np.zeros((len(path), 1, 2))
    return np.concatenate([origin, np.cumsum(steps, axis=1)], axis=1)


def fingertips(base: BaseConf, q: JointConf) -> FloatArray:
    """World position of the fingertips."""
    return _to_world(base, joint_points(q)[-1:])[0]


def _to_world(base: BaseConf, planar: FloatArray) -> FloatArray:
    """Planar arm points (forward, up from the shoulder) to world ``(x, y, z)``."""
    c, s = np.cos(base.theta), np.sin(base.theta)
    fwd = planar[:, 0] + SHOULDER_FORWARD
    return np.stack([base.x + c * fwd, base.y + s * fwd, planar[:, 1] + SHOULDER_HEIGHT], axis=1)


def arm_points(base: BaseConf, path: FloatArray) -> FloatArray:
    """World points sampled along the links for every configuration of ``path`` (m, 3)."""
    joints = _joints(np.asarray(path, dtype=float))
    t = np.linspace(0.0, 1.0, POINTS_PER_LINK, endpoint=False)[None, None, :, None]
    a, b = joints[:, :-1, None, :], joints[:, 1:, None, :]
    along = (a * (1 - t) + b * t).reshape(-1, 2)
    return _to_world(base, np.vstack([along, joints[:, -1, :]]))


def arm_free(base: BaseConf, path: FloatArray, furniture: tuple[Box, ...]) -> bool:
    """No link point of any configuration is inside a piece of furniture or below knee height."""
    pts = arm_points(base, path)
    if (pts[:, 2] < 0.3).any():
        return False
    for box in furniture:
        r = box.rect
        hit = (
            (pts[:, 0] > r.x0 - CLEARANCE)
            & (pts[:, 0] < r.x1 + CLEARANCE)
            & (pts[:, 1] > r.y0 - CLEARANCE)
            & (pts[:, 1] < r.y1 + CLEARANCE)
            & (pts[:, 2] < box.height + CLEARANCE)
        )
        if hit.any():
            return False
    return True


def interpolate(a: JointConf, b: JointConf) -> FloatArray:
    """Joint-space straight line from ``a`` to ``b``, no joint moving more than STEP per point."""
    qa, qb = np.array(a), np.array(b)
    n = max(int(np.ceil(np.abs(qb - qa).max() / STEP)), 1)
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    return np.asarray(qa[None, :] * (1 - t) + qb[None, :] * t, dtype=float)


def cartesian(a: PlanarTarget, b: PlanarTarget) -> FloatArray | None:
    """IK solutions along the straight hand motion from ``a`` to ``b`` (same hand angle)."""
    n = max(int(np.ceil(np.hypot(b.r - a.r, b.z - a.z) / CARTESIAN_STEP)), 1)
    out = []
    for t in np.linspace(0.0, 1.0, n + 1):
        q = solve_ik(PlanarTarget(a.r + t * (b.r - a.r), a.z + t * (b.z - a.z), a.phi))
        if q is None:
            return None
        out.append(q)
    path = np.array(out, dtype=float)
    if len(path) > 1 and np.abs(np.diff(path, axis=0)).max() > MAX_JUMP:
        return None
    return path


def approach_path(
    base: BaseConf, obj: ObjectSpec, pose: ObjPose, grasp: Grasp, furniture: tuple[Box, ...]
) -> FloatArray | None:
    """Tucked -> ready (hand raised near the body) -> pre-grasp -> grasp, the last two as
    straight hand motions; collision-checked. None when IK or the check fails."""
    phi = hand_angle(grasp)
    target = planar_target(base, grasp_point(obj, pose, grasp), phi)
    back = (APPROACH, 0.0) if grasp.kind == "side" else (0.0, -APPROACH)
    pre = PlanarTarget(target.r - back[0], target.z - back[1], phi)
    ready = PlanarTarget(READY[0], max(pre.z, target.z) + READY[1], phi)
    q_ready = solve_ik(ready)
    reach = cartesian(ready, pre)
    final = cartesian(pre, target)
    if q_ready is None or reach is None or final is None:
        return None
    path = densify(np.vstack([interpolate(TUCKED, q_ready), reach[1:], final[1:]]))
    return path if arm_free(base, path, furniture) else None


def densify(path: FloatArray) -> FloatArray:
    """``path`` with points interpolated so that no joint moves more than STEP between two."""
    parts = [path[:1]]
    for a, b in itertools.pairwise(path):
        parts.append(interpolate((a[0], a[1], a[2]), (b[0], b[1], b[2]))[1:])
    return np.vstack(parts)
