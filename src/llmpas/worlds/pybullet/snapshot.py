"""Scene snapshots (PNG) and animations (GIF) from an overview camera, without a window."""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from llmpas.files import atomic_write
from llmpas.worlds.pybullet.camera import CameraConfig, Image, render
from llmpas.worlds.pybullet.scene import Scene

log = logging.getLogger(__name__)


def overview(scene: Scene, config: CameraConfig | None = None) -> Image:
    """The whole scene from above and behind its centre (tables and robot in view)."""
    rects = list(scene.tables.values())
    bx, by, _ = scene.base_pose()
    xs = [r.center[0] for r in rects] + [bx]
    ys = [r.center[1] for r in rects] + [by]
    cx, cy = float(np.mean(xs)), float(np.mean(ys))
    span = max(max(xs) - min(xs), max(ys) - min(ys), 1.0)
    eye = (cx - 0.55 * span - 0.6, cy - 0.55 * span - 0.6, 0.9 * span + 1.0)
    return render(
        scene, eye, (cx, cy, 0.4), config=config or CameraConfig(width=480, height=360, fov=60.0)
    )


def save_png(rgb: np.ndarray, path: str | Path) -> Path:
    from PIL import Image as PILImage

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    PILImage.fromarray(np.asarray(rgb, dtype=np.uint8)).save(out)
    return out


def save_gif(frames: Sequence[np.ndarray], path: str | Path, frame_ms: int = 200) -> Path:
    """An animated GIF of ``frames`` (H, W, 3 uint8 arrays of one size)."""
    from PIL import Image as PILImage

    if not frames:
        raise ValueError("no frames to animate")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    images = [PILImage.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    images[0].save(
        out, save_all=True, append_images=images[1:], duration=frame_ms, loop=0, optimize=False
    )
    return out


def is_blank(rgb: np.ndarray, min_std: float = 5.0) -> bool:
    """Whether an image is (nearly) uniform: a failed render."""
    return float(np.asarray(rgb, dtype=float).std()) < min_std


class Shot(Protocol):
    """A labelled image made at a mark (episodes executed before it, timeline events before it):
    a :class:`~llmpas.worlds.pybullet.pybullet_robot.Frame`."""

    label: str
    rgb: np.ndarray
    mark: tuple[int, int]


def save_media(frames: Sequence[Shot], images: Sequence[Shot], folder: str | Path) -> list[Path]:
    """Overview snapshots (``snapshots/``), camera views (``camera/``), ``media.json`` (where
    each image was made, for the web report) and ``episode.gif`` of the snapshots."""
    folder = Path(folder)
    written: list[Path] = []
    media = []
    for kind, sub, shots in (("snapshot", "snapshots", frames), ("camera", "camera", images)):
        for i, frame in enumerate(shots):
            slug = "".join(ch if ch.isalnum() else "-" for ch in frame.label.lower())[:40]
            path = save_png(frame.rgb, folder / sub / f"{i:02d}-{slug}.png")
            written.append(path)
            episode, event = frame.mark
            media.append(
                {"file": f"{sub}/{path.name}", "kind": kind, "label": frame.label}
                | {"episode": episode, "event": event}
            )
    written.append(atomic_write(folder / "media.json", json.dumps(media, indent=2)))
    if frames:
        written.append(save_gif([f.rgb for f in frames], folder / "episode.gif", 500))
    return written
