"""A ROS 2 run as a rosbag2-format MCAP (``ros2msg`` schemas, CDR messages): goals, feedback and
results of every action, the robot's topics, and anomalies as ``diagnostic_msgs/DiagnosticArray``.
Opens in Foxglove and ``ros2 bag``; read back with ``mcap``/``mcap-ros2-support``."""

from __future__ import annotations

import importlib
import re
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

SEPARATOR = "=" * 80
PRIMITIVES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
        "wstring",
    }
)


def _share(package: str) -> Path:
    """Where a package's interface files are installed (``<prefix>/share/<package>``)."""
    module = importlib.import_module(package)
    return Path(str(module.__file__)).resolve().parents[4] / "share" / package


def _base_type(field_type: str, package: str) -> str | None:
    t = re.sub(r"\[.*\]$", "", field_type)
    t = re.sub(r"<=\d+$", "", t)
    if t in PRIMITIVES:
        return None
    if t == "Header":
        return "std_msgs/msg/Header"
    parts = t.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{t}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return t


def _fields(text: str) -> list[str]:
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line or "=" in line.split()[-1] or (len(line.split()) > 2 and "=" in line):
            continue
        out.append(line.split()[0])
    return out


def interface_text(name: str) -> str:
    """The text of ``pkg/msg/Name`` or ``pkg/action/Name_Goal`` (``_Result``, ``_Feedback``)."""
    package, kind, base = name.split("/")
    if kind == "action":
        stem, _, part = base.rpartition("_")
        sections = (_share(package) / "action" / f"{stem}.action").read_text().split("---")
        return sections[{"Goal": 0, "Result": 1, "Feedback": 2}[part]].strip() + "\n"
    return (_share(package) / kind / f"{base}.{kind}").read_text()


def message_definition(name: str) -> str:
    """A type's ``ros2msg`` schema: its text, then each type it uses (``MSG:`` sections)."""
    package = name.split("/")[0]
    text = interface_text(name)
    seen: list[str] = []
    todo = [_base_type(f, package) for f in _fields(text)]
    while todo:
        t = todo.pop(0)
        if t is None or t in seen:
            continue
        seen.append(t)
        sub = interface_text(t)
        todo.extend(_base_type(f, t.split("/")[0]) for f in _fields(sub))
    parts = [text.rstrip("\n")]
    for t in seen:
        parts.append(f"{SEPARATOR}\nMSG: {t}\n{interface_text(t).rstrip()}")
    return "\n".join(parts) + "\n"


class McapRecorder:
    """Writes messages to an MCAP file as they come (thread-safe), one channel per topic."""

    def __init__(self, path: Path) -> None:
        from mcap.writer import Writer

        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = path.open("wb")
        self._writer = Writer(self._file)
        self._writer.start(profile="ros2", library="llmpas")
        self._lock = threading.Lock()
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self.types: dict[str, str] = {}
        self.counts: Counter[str] = Counter()
        self.closed = False

    def _channel(self, topic: str, type_name: str) -> int:
        if topic in self._channels:
            return self._channels[topic]
        if type_name not in self._schemas:
            data = message_definition(type_name).encode()
            self._schemas[type_name] = self._writer.register_schema(type_name, "ros2msg", data)
        cid = self._writer.register_channel(topic, "cdr", self._schemas[type_name])
        self._channels[topic] = cid
        self.types[topic] = type_name
        return cid

    def write(self, topic: str, type_name: str, msg: Any, t_ns: int | None = None) -> None:
        from rclpy.serialization import serialize_message

        data = serialize_message(msg)
        now = time.time_ns() if t_ns is None else t_ns
        with self._lock:
            if self.closed:
                return
            cid = self._channel(topic, type_name)
            self._writer.add_message(cid, log_time=now, data=data, publish_time=now)
            self.counts[topic] += 1

    def close(self) -> None:
        with self._lock:
            if not self.closed:
                self.closed = True
                self._writer.finish()
                self._file.close()


def type_name(msg: Any) -> str:
    """``pkg/msg/Name`` (or ``pkg/action/Name_Goal``) of a generated message instance."""
    cls = type(msg)
    module = cls.__module__.split(".")  # pkg.msg._name / pkg.action._name
    return f"{module[0]}/{module[1]}/{cls.__name__}"


__all__ = ["McapRecorder", "message_definition", "type_name"]
