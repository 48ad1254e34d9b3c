"""Cameras and object detection from rendered images.

Two cameras: a pan-tilt head on a mast of the Husky (``look_at`` a point) and a wrist camera on
the Panda's hand (looking along the gripper). Images come from PyBullet's TinyRenderer (no window,
no GPU). Detection reads the segmentation mask: every movable object with enough pixels in view is
detected, its pixels are unprojected with the depth buffer to world points, and its position is
estimated from them (the top face's extent for a cube, the extent for a bowl), with seeded
Gaussian noise from an explicit ``numpy.random.Generator``. Nothing here reads an object's true
pose: only the rendered image.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from llmpas.execution.robot_protocols import Detection, Observation
from llmpas.worlds.pybullet.pybullet_values import ObjectPose, Vector
from llmpas.worlds.pybullet.scene import HAND_LINK, RIM_MARGIN, Scene

MAST = (0.05, 0.0, 1.25)  # the head on the Husky (base frame)


@dataclass(frozen=True)
class CameraConfig:
    width: int = 320
    height: int = 240
    fov: float = 60.0  # vertical, degrees
    near: float = 0.05
    far: float = 5.0
    noise: float = 0.005  # metres, standard deviation of a detected position (x, y and z)
    min_pixels: int = 12  # fewer pixels of an object: not detected

    def __post_init__(self) -> None:
        if not (16 <= self.width <= 2048 and 16 <= self.height <= 2048):
            raise ValueError(f"image size {self.width}x{self.height} out of range")
        if not 5.0 <= self.fov <= 150.0:
            raise ValueError(f"fov {self.fov} out of [5, 150]")
        if not 0 < self.near < self.far:
            raise ValueError("need 0 < near < far")
        if self.noise < 0 or self.min_pixels < 1:
            raise ValueError("noise must be >= 0 and min_pixels >= 1")


@dataclass(frozen=True)
class Image:
    """One rendered view: colour (H, W, 3 uint8), depth (H, W metres), segmentation (H, W body
    ids, -1 for background), and the matrices it was rendered with."""

    rgb: np.ndarray
    depth: np.ndarray
    seg: np.ndarray
    view: np.ndarray  # 4x4, world -> camera (OpenGL)
    proj: np.ndarray  # 4x4
    eye: tuple[float, float, float]
    zbuf: np.ndarray  # the raw depth buffer in [0, 1], for unprojection

    def pixels_of(self, body: int) -> int:
        return int(np.count_nonzero(self.seg == body))

    def points(self, mask: np.ndarray) -> np.ndarray:
        """World points (N, 3) of the masked pixels, from the depth buffer."""
        h, w = self.seg.shape
        v, u = np.nonzero(mask)
        zbuf = self.zbuf[v, u]
        x = 2.0 * (u + 0.5) / w - 1.0
        y = 1.0 - 2.0 * (v + 0.5) / h
        z = 2.0 * zbuf - 1.0
        ndc = np.stack([x, y, z, np.ones_like(x)])
        world = np.linalg.inv(self.proj @ self.view) @ ndc
        return (world[:3] / world[3]).T


def _matrix(flat: Sequence[float]) -> np.ndarray:
    return np.asarray(flat, dtype=float).reshape(4, 4).T  # PyBullet: column-major


def render(
    scene: Scene,
    eye: Vector,
    target: Vector,
    up: Vector = (0.0, 0.0, 1.0),
    config: CameraConfig | None = None,
) -> Image:
    cfg = config or CameraConfig()
    c = scene.client
    view = p.computeViewMatrix(list(eye), list(target), list(up), physicsClientId=c)
    proj = p.computeProjectionMatrixFOV(
        cfg.fov, cfg.width / cfg.height, cfg.near, cfg.far, physicsClientId=c
    )
    _, _, rgba, zbuf, seg = p.getCameraImage(
        cfg.width,
        cfg.height,
        view,
        proj,
        renderer=p.ER_TINY_RENDERER,
        physicsClientId=c,
    )
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(cfg.height, cfg.width, 4)[:, :, :3]
    z = np.asarray(zbuf, dtype=float).reshape(cfg.height, cfg.width)
    depth = cfg.far * cfg.near / (cfg.far - (cfg.far - cfg.near) * z)
    seg_ids = np.asarray(seg, dtype=np.int64).reshape(cfg.height, cfg.width)
    return Image(rgb, depth, seg_ids, _matrix(view), _matrix(proj), (eye[0], eye[1], eye[2]), z)


def mast_eye(scene: Scene) -> tuple[float, float, float]:
    x, y, yaw = scene.base_pose()
    mx, my, mz = MAST
    return (
        x + mx * math.cos(yaw) - my * math.sin(yaw),
        y + mx * math.sin(yaw) + my * math.cos(yaw),
        mz,
    )


def look_at(scene: Scene, target: Sequence[float], config: CameraConfig | None = None) -> Image:
    """The mast camera pointed at ``target``."""
    return render(scene, mast_eye(scene), target, config=config)


def wrist_image(scene: Scene, config: CameraConfig | None = None) -> Image:
    """The wrist camera: at the hand, looking along the gripper's approach axis."""
    s = p.getLinkState(
        scene.panda, HAND_LINK, computeForwardKinematics=True, physicsClientId=scene.client
    )
    pos, orn = np.array(s[4]), s[5]
    m = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
    axis, up = m[:, 2], m[:, 0]
    eye = pos + 0.05 * m[:, 0] + 0.02 * axis  # beside the fingers, looking past them
    return render(scene, eye, eye + axis, up, config)


def detect(
    scene: Scene,
    image: Image,
    rng: np.random.Generator,
    config: CameraConfig | None = None,
) -> Observation:
    """What ``image`` shows: detections of the movable objects with seeded noise, and the
    regions (tables, bowls) in view."""
    cfg = config or CameraConfig()
    estimates: dict[str, tuple[np.ndarray, int]] = {}
    for o in scene.config.objects:
        body = scene.bodies[o.name]
        mask = image.seg == body
        n = int(np.count_nonzero(mask))
        if n < cfg.min_pixels:
            continue
        pts = image.points(mask)
        if o.graspable:  # its top face (a lid's: its knob's) gives its centre
            top = pts[pts[:, 2] >= pts[:, 2].max() - 0.01]
            xy = (top[:, :2].min(axis=0) + top[:, :2].max(axis=0)) / 2
            z = float(pts[:, 2].max()) - o.height / 2
        else:
            xy = (pts[:, :2].min(axis=0) + pts[:, :2].max(axis=0)) / 2
            z = float(pts[:, 2].min())
        est = np.array([xy[0], xy[1], z]) + rng.normal(0.0, cfg.noise, 3)
        estimates[o.name] = (est, n)
    bowls = {
        o.name: estimates[o.name][0]
        for o in scene.config.objects
        if o.kind == "bowl" and o.name in estimates
    }
    detections = []
    for name, (est, n) in sorted(estimates.items()):
        region = _region(scene, name, est, bowls)
        conf = min(1.0, n / 200.0)
        pose = ObjectPose(region or "unknown", *(round(float(v), 4) for v in est))
        detections.append(Detection(name, pose.region, pose, conf))
    viewed = tuple(sorted(set(_tables_in_view(scene, image)) | set(bowls)))
    return Observation(viewed, tuple(detections))


def _region(scene: Scene, name: str, est: np.ndarray, bowls: dict[str, np.ndarray]) -> str | None:
    """A bowl when the object is over its inside and its bottom below the bowl's rim; else the
    table under it (an object lying on a bowl's rim, a lid on it, is not in the bowl)."""
    o = scene.config.obj(name)
    bottom = float(est[2]) - o.origin_height
    for b, at in bowls.items():
        bowl = scene.config.obj(b)
        half = bowl.size / 2
        inside = abs(est[0] - at[0]) <= half and abs(est[1] - at[1]) <= half
        if b != name and inside and bottom < float(at[2]) + bowl.height - RIM_MARGIN:
            return b
    for t, rect in scene.tables.items():
        if rect.contains(float(est[0]), float(est[1])):
            return t
    return None


def _tables_in_view(scene: Scene, image: Image) -> list[str]:
    """Tables whose top's centre is in the image and not hidden (its pixels there)."""
    out = []
    h, w = image.seg.shape
    for t, rect in scene.tables.items():
        body = scene.bodies[t]
        cx, cy = rect.center
        clip = image.proj @ image.view @ np.array([cx, cy, 0.626, 1.0])
        if clip[3] <= 0:
            continue
        u = (clip[0] / clip[3] + 1) / 2 * w
        v = (1 - clip[1] / clip[3]) / 2 * h
        if 0 <= u < w and 0 <= v < h and image.pixels_of(body) >= 0.02 * h * w:
            out.append(t)
    return out
