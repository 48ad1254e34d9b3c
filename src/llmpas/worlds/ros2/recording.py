"""What a ROS 2 session records and writes: the profile's topics and every goal into an MCAP,
each anomaly as a DiagnosticArray on ``/diagnostics``, ``ros.json`` and ``artifacts.json``
(a mix-in of the sessions that drive a robot over ROS 2)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

from llmpas.files import atomic_write
from llmpas.worlds.ros2.rosbag import McapRecorder, type_name

BAG = "ros.mcap"


class Recording:
    """Recording for a session with ``robot`` (its node), ``profile``, ``bag``, ``context``,
    ``folder`` (the session's own), ``timings`` and ``achieved()``."""

    robot: Any
    profile: Any
    bag: McapRecorder
    context: Any
    folder: Path
    timings: dict[str, float]
    rounds: int
    episodes: int
    anomalies: int
    saved: bool
    _recorder: Any
    _seen: int

    def about(self) -> dict[str, Any]:
        """More for ``ros.json`` (the session's)."""
        return {}

    def _subscribe(self, key: str, module: str, name: str) -> Any:
        """Record the profile's topic ``key`` with the profile's QoS (a subscription that asks
        more than the publisher offers, RELIABLE of a best-effort one or TRANSIENT_LOCAL of a
        VOLATILE one, gets nothing)."""
        import importlib

        kind = getattr(importlib.import_module(module), name)
        topic = getattr(self.profile.topics, key)
        full = f"{module.split('.')[0]}/msg/{name}"
        channel = self.robot.node.resolve_topic_name(topic.name)
        return self.robot.node.create_subscription(
            kind, topic.name, lambda msg: self.bag.write(channel, full, msg), topic.qos.rclpy()
        )

    def _record_goal(self, channel: str, kind: str, msg: Any) -> None:
        namespace = self.profile.namespace
        if namespace and not channel.startswith(namespace + "/"):
            channel = namespace + channel  # the llmpas client's channels are relative
        self.bag.write(channel, type_name(msg), msg)
        if kind == "Goal":
            self._record_anomalies()

    def _record_anomalies(self) -> None:
        """The executor's anomalies so far (its timeline, one per round), as
        DiagnosticArray messages on ``/diagnostics``."""
        current = self.context.recorder
        if current is not self._recorder:
            self._flush(self._recorder)
            self._recorder, self._seen = current, 0
        self._flush(current)

    def _flush(self, recorder: Any) -> None:
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        if recorder is None:
            return
        events = recorder.events
        if recorder is not self._recorder:
            start = self._seen
        else:
            start, self._seen = self._seen, len(events)
        for e in events[start:]:
            if e.status != "anomaly":
                continue
            status = DiagnosticStatus()
            status.level, status.name = DiagnosticStatus.ERROR, f"llmpas/anomaly/{e.node}"
            status.message, status.hardware_id = e.message, "llmpas"
            status.values = [KeyValue(key=k, value=v) for k, v in e.values.items()]
            msg = DiagnosticArray()
            msg.status = [status]
            self.bag.write("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", msg)
            self.anomalies += 1

    # ------------------------------------------------------------------ files

    def save(self, folder: Path) -> list[Path]:
        """The MCAP (moved into the run folder; recording goes on there) and ``ros.json``."""
        self._record_anomalies()
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        self.rounds = self.episodes
        about = {
            "scenario": self.name,  # type: ignore[attr-defined]
            "achieved": self.achieved(),  # type: ignore[attr-defined]
            **self.about(),
            "timings": self.timings,
            "goals": self.robot.goals,
            "environment": {  # this process's, set before rclpy started
                k: os.environ.get(k, "")
                for k in (
                    "ROS_AUTOMATIC_DISCOVERY_RANGE",
                    "ROS_DOMAIN_ID",
                    "ROS_LOG_DIR",
                    "RMW_IMPLEMENTATION",
                )
            },
            "anomalies": self.anomalies,
            "bag": BAG,
            "channels": {
                t: {"type": self.bag.types[t], "messages": n}
                for t, n in sorted(self.bag.counts.items())
            },
            "profile": {
                "name": self.profile.name,
                "interfaces": self.profile.interfaces,
                "namespace": self.profile.namespace,
                "file": self.profile.source,
            },
            "holds": "the goals, feedback and results of every action, the robot's odometry, "
            "joint states, detections and scene markers (a standard robot's: TF), and each "
            "anomaly as diagnostic_msgs/DiagnosticArray on /diagnostics",
        }
        artifact = {
            "file": BAG,
            "title": "ROS 2 recording (rosbag2 MCAP: Foxglove, ros2 bag)",
            "holds": about["holds"],
        }
        written = [
            atomic_write(folder / "ros.json", json.dumps(about, indent=2)),
            atomic_write(folder / "artifacts.json", json.dumps([artifact], indent=2)),
        ]
        self.bag.close()
        target = folder / BAG
        if self.bag.path.resolve() != target.resolve():
            shutil.copyfile(self.bag.path, target)
        written.append(target)
        for name in ("robot.log", "log"):  # the robot node's output and the ROS logs
            source = self.folder / name
            if source.is_file():
                written.append(Path(shutil.copyfile(source, folder / f"ros-{name}")))
            elif source.is_dir():
                shutil.copytree(source, folder / "ros-log", dirs_exist_ok=True)
        self.saved = True
        return written


__all__ = ["BAG", "Recording"]
