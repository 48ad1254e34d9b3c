"""A picture of a ``run.mcap`` without Foxglove: its scene channels read back and drawn from
above (the robot's belief solid, the truth faint, the robot's frames as arrows) when the
anomaly was reported and at the end, and a timeline of every channel's messages.

``python -m llmpas.reporting.mcap_picture RUN.mcap OUT.png`` (needs ``mcap`` and
``mcap-protobuf-support``, which decode the SDK's protobuf schemas).
"""

from __future__ import annotations

import json
import logging
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)


@dataclass
class Read:
    """What the picture needs of a run.mcap."""

    times: dict[str, list[int]] = field(default_factory=dict)  # topic -> log times (ns)
    scenes: list[tuple[int, Any]] = field(default_factory=list)  # (time, SceneUpdate)
    truths: list[tuple[int, Any]] = field(default_factory=list)
    frames: list[tuple[int, Any]] = field(default_factory=list)  # (time, FrameTransforms)
    anomalies: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    verdicts: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    status: str = ""


def read(path: Path) -> Read:
    from mcap.decoder import DecoderFactory as Factory
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    class _JSON(Factory):
        """mcap's decoder factory for the JSON channels."""

        def decoder_for(self, message_encoding: str, schema: Any) -> Any:
            return json.loads if message_encoding == "json" else None

    out = Read()
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory(), _JSON()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            t, topic = message.log_time, channel.topic
            out.times.setdefault(topic, []).append(t)
            if topic == "/llmpas/scene":
                out.scenes.append((t, decoded))
            elif topic == "/llmpas/scene/truth":
                out.truths.append((t, decoded))
            elif topic == "/llmpas/tf":
                out.frames.append((t, decoded))
            elif topic == "/llmpas/anomaly":
                out.anomalies.append((t, decoded))
            elif topic == "/llmpas/llm" and decoded.get("kind") == "verdict":
                out.verdicts.append((t, decoded))
            elif topic == "/llmpas/loop":
                out.status = f"{decoded.get('status')}: {decoded.get('message')}"
    return out


def at(items: Sequence[tuple[int, Any]], t: float) -> Any:
    """The last item logged at or before ``t`` (the first one if none)."""
    before = [m for s, m in items if s <= t]
    return before[-1] if before else (items[0][1] if items else None)


def _yaw(q: Any) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def _draw_scene(ax: Any, scene: Any, truth: Any, frames: Any, title: str) -> None:
    from matplotlib.patches import Rectangle

    def places(update: Any) -> None:
        for e in update.entities if update is not None else []:
            if "/place/" not in e.id:
                continue
            for c in e.cubes:
                p, s, q = c.pose.position, c.size, c.pose.orientation
                w, h = (s.y, s.x) if abs(math.sin(_yaw(q))) > 0.5 else (s.x, s.y)
                colour = (c.color.r, c.color.g, c.color.b)
                ax.add_patch(Rectangle((p.x - w / 2, p.y - h / 2), w, h, facecolor=colour,
                                       alpha=0.5, edgecolor="black", zorder=1))  # fmt: skip
                ax.annotate(e.id.rsplit("/", 1)[-1], (p.x, p.y + h / 2), fontsize=8,
                            ha="center", va="bottom")  # fmt: skip

    def objects(update: Any, true: bool) -> None:
        # objects are centimetres wide: drawn as markers of a fixed size, labelled
        for e in update.entities if update is not None else []:
            if "/object/" not in e.id:
                continue
            for c in e.cubes:
                p = c.pose.position
                colour = (c.color.r, c.color.g, c.color.b)
                name = e.id.rsplit("/", 1)[-1]
                if true:
                    ax.scatter([p.x], [p.y], s=150, facecolors="none", edgecolors=[colour],
                               linewidths=2, linestyle="--", zorder=3)  # fmt: skip
                    at = {"xytext": (6, -12), "textcoords": "offset points"}
                    ax.annotate(f"{name} (true)", (p.x, p.y), fontsize=7, color="dimgray", **at)
                else:
                    ax.scatter([p.x], [p.y], s=60, c=[colour], marker="s", edgecolors="black",
                               zorder=4)  # fmt: skip
                    ax.annotate(name, (p.x, p.y), xytext=(6, 4), textcoords="offset points",
                                fontsize=7)  # fmt: skip

    places(scene)
    objects(scene, False)
    objects(truth, True)
    for f in frames.transforms if frames is not None else []:
        if f.parent_frame_id != "world" or f.child_frame_id not in ("base_link", "gripper"):
            continue  # the arm's links would crowd a view from above
        x, y = f.translation.x, f.translation.y
        if f.child_frame_id == "base_link":
            yaw = _yaw(f.rotation)
            ax.arrow(x, y, 0.35 * math.cos(yaw), 0.35 * math.sin(yaw), width=0.03,
                     color="crimson", zorder=5)  # fmt: skip
        else:
            ax.scatter([x], [y], marker="x", color="crimson", zorder=5)
        ax.annotate(f.child_frame_id, (x, y), xytext=(-4, -10), textcoords="offset points",
                    fontsize=7, color="crimson", ha="right")  # fmt: skip
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.margins(0.12)
    ax.grid(alpha=0.3)


def draw(path: str | Path, png: str | Path) -> Path:
    """Draw ``path`` (a run.mcap) into ``png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = read(Path(path))
    if not r.scenes:
        raise ValueError(f"{path}: no /llmpas/scene messages")
    t0 = min(min(ts) for ts in r.times.values())
    anomaly_t = r.anomalies[0][0] if r.anomalies else r.scenes[0][0]
    end_t = r.scenes[-1][0]
    fig = plt.figure(figsize=(12, 7.5), dpi=110)
    grid = fig.add_gridspec(2, 2, height_ratios=[2.2, 1.0])
    first, last = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])
    what = r.anomalies[0][1]["text"] if r.anomalies else "no anomaly"
    short = what if len(what) < 90 else what[:87] + "..."
    _draw_scene(first, at(r.scenes, anomaly_t), at(r.truths, anomaly_t),
                at(r.frames, anomaly_t), f"/llmpas/scene at the anomaly\n{short}")  # fmt: skip
    goals = " ".join(r.verdicts[-1][1].get("goals", [])) if r.verdicts else ""
    _draw_scene(last, at(r.scenes, end_t), at(r.truths, end_t), at(r.frames, end_t),
                f"/llmpas/scene at the end ({r.status})\nLLM goals: {goals}")  # fmt: skip
    ax = fig.add_subplot(grid[1, :])
    topics = sorted(r.times)
    for k, topic in enumerate(topics):
        xs = [(t - t0) / 1e9 for t in r.times[topic]]
        ax.scatter(xs, [k] * len(xs), s=12, marker="|" if len(xs) > 30 else "o")
    for t, _ in r.anomalies:
        ax.axvline((t - t0) / 1e9, color="crimson", linestyle="--", linewidth=1)
    ax.set_yticks(range(len(topics)), topics, fontsize=8)
    ax.set_xlabel("seconds into the run (log time)")
    ax.set_title("every channel's messages (dashed: the anomaly)", fontsize=9)
    ax.grid(alpha=0.3)
    fig.suptitle(
        f"{Path(path).name} read back: objects where the robot believes them (squares) and "
        "where they truly are (dashed circles),\nthe robot's base (arrow) and gripper (x)"
    )
    fig.tight_layout()
    out = Path(png)
    fig.savefig(out)
    plt.close(fig)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 2:
        log.error("usage: python -m llmpas.reporting.mcap_picture RUN.mcap OUT.png")
        return 2
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    log.info("wrote %s", draw(args[0], args[1]))
    return 0


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["Read", "at", "draw", "read"]
