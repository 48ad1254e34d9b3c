"""A robot profile: what llmpas needs to know to drive one ROS 2 robot (``--robot-profile FILE``).

A YAML file names the robot's action servers, topics and frames (relative names resolve in the
profile's ``namespace``, as ROS 2 resolves them in a node's), the arm's joints, the QoS of every
topic llmpas subscribes to (to match the robot's publishers: joint_state_broadcaster and
diff_drive_controller publish VOLATILE, a camera's detector often best effort), the places
(regions with their frame and footprint), the furniture (static geometry of the planning scene),
what a look is, which interfaces the robot speaks (``llmpas``: the project's own ``Skill``,
``Look`` and ``GetSceneState`` besides Nav2 and ros2_control; ``standard``: Nav2, ros2_control,
TF, ``joint_states``, ``robot_description`` and ``vision_msgs`` only) and the RMW (none: the
user's ``RMW_IMPLEMENTATION``, else ROS 2's default).

Every key is optional; a missing one takes the shipped PyBullet robot's value. A bad profile is
a :class:`ProfileError` naming the file and the key. Shipped profiles (``pybullet``,
``pybullet-standard``) are in ``profiles/`` next to this module.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, TypeVar

PROFILES = Path(__file__).resolve().parent / "profiles"
INTERFACES = ("llmpas", "standard")
RELIABILITY = ("reliable", "best_effort")
DURABILITY = ("volatile", "transient_local")
CAMERAS = ("mast", "arm", "wrist")
PANDA = tuple(f"panda_joint{i}" for i in range(1, 8))
HOME = (0.0, -1.7, 0.0, -3.0, 0.0, 1.4, 0.785)


class ProfileError(ValueError):
    """A robot profile that cannot be used: ``FILE: KEY: what is wrong``."""


def _name(value: str, what: str) -> None:
    if not value or any(c.isspace() for c in value) or "//" in value or value.endswith("/"):
        raise ValueError(f"{what}: {value!r} is not a ROS 2 name")


@dataclass(frozen=True)
class Qos:
    """A subscription's QoS (it must be compatible with the publisher's: a RELIABLE or
    TRANSIENT_LOCAL subscriber gets nothing from a best-effort or VOLATILE publisher)."""

    reliability: str = "reliable"
    durability: str = "volatile"
    depth: int = 10

    def __post_init__(self) -> None:
        if self.reliability not in RELIABILITY:
            raise ValueError(f"reliability: one of {', '.join(RELIABILITY)}")
        if self.durability not in DURABILITY:
            raise ValueError(f"durability: one of {', '.join(DURABILITY)}")
        if not 1 <= self.depth <= 1000:
            raise ValueError("depth: 1..1000")

    def rclpy(self) -> Any:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        return QoSProfile(
            depth=self.depth,
            reliability=ReliabilityPolicy.RELIABLE
            if self.reliability == "reliable"
            else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL
            if self.durability == "transient_local"
            else DurabilityPolicy.VOLATILE,
        )


SENSOR = Qos("best_effort", "volatile", 10)
LATCHED = Qos("reliable", "transient_local", 1)


@dataclass(frozen=True)
class Topic:
    name: str
    qos: Qos = field(default_factory=Qos)

    def __post_init__(self) -> None:
        _name(self.name, "name")


@dataclass(frozen=True)
class Frames:
    map: str = "map"
    odom: str = "odom"
    base: str = "base_link"

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not v or v.startswith("/") or any(c.isspace() for c in v):
                raise ValueError(f"{f.name}: {v!r} is not a frame id")


@dataclass(frozen=True)
class Actions:
    """Action servers (and the llmpas state service)."""

    navigate: str = "navigate_to_pose"
    arm: str = "arm_controller/follow_joint_trajectory"
    gripper: str = "gripper_controller/gripper_cmd"
    skill: str = "llmpas/skill"
    look: str = "llmpas/look"
    state: str = "llmpas/scene_state"

    def __post_init__(self) -> None:
        for f in fields(self):
            _name(getattr(self, f.name), f.name)


@dataclass(frozen=True)
class Topics:
    odom: Topic = Topic("odom")
    joint_states: Topic = Topic("joint_states")
    detections: Topic = Topic("detections")
    wrist_detections: Topic = Topic("wrist/detections")
    scene_markers: Topic = Topic("scene_markers")
    tf: Topic = Topic("/tf", Qos(depth=100))
    tf_static: Topic = Topic("/tf_static", Qos("reliable", "transient_local", 100))
    robot_description: Topic = Topic("robot_description", LATCHED)


@dataclass(frozen=True)
class Arm:
    joints: tuple[str, ...] = PANDA
    home: tuple[float, ...] = HOME
    gripper_open: float = 0.04  # a GripperCommand position that opens the hand (m)
    max_effort: float = 60.0  # N, to close on an object
    seconds_per_point: float = 0.05  # time_from_start between a planned path's points

    def __post_init__(self) -> None:
        if not self.joints or len(set(self.joints)) != len(self.joints):
            raise ValueError("joints: a list of distinct joint names")
        if len(self.home) != len(self.joints):
            raise ValueError(f"home: {len(self.joints)} positions, one per joint")
        if self.gripper_open <= 0 or self.max_effort <= 0 or self.seconds_per_point <= 0:
            raise ValueError("gripper_open, max_effort and seconds_per_point must be positive")


@dataclass(frozen=True)
class Place:
    """A region the planner names (a table), its footprint a polygon in ``frame``."""

    name: str
    frame: str = "map"
    footprint: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("name: empty")
        if len(self.footprint) < 3:
            raise ValueError("footprint: at least three [x, y] points")

    def contains(self, x: float, y: float) -> bool:
        inside = False
        pts = self.footprint
        for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True):
            if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
                inside = not inside
        return inside


@dataclass(frozen=True)
class Furniture:
    """A static box of the planning scene: its size and its centre pose (x, y, z, yaw)."""

    name: str
    frame: str = "map"
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)
    pose: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("name: empty")
        if len(self.size) != 3 or min(self.size) <= 0:
            raise ValueError("size: three positive numbers")
        if len(self.pose) != 4:
            raise ValueError("pose: [x, y, z, yaw]")


@dataclass(frozen=True)
class Look:
    """What a look with one camera is: the detections topic that answers it, how long to wait
    for a fresh message, and (for a camera on the arm) joint positions to look from."""

    camera: str
    detections: str = "detections"  # a key of Topics
    wait: float = 5.0
    joints: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.camera not in CAMERAS:
            raise ValueError(f"camera: one of {', '.join(CAMERAS)}")
        if self.detections not in {f.name for f in fields(Topics)}:
            raise ValueError(f"detections: a topic key, not {self.detections!r}")
        if not 0 < self.wait <= 300:
            raise ValueError("wait: seconds in (0, 300]")


def _default_looks() -> tuple[Look, ...]:
    return (Look("mast"), Look("arm", "wrist_detections"), Look("wrist", "wrist_detections"))


@dataclass(frozen=True)
class RobotProfile:
    name: str = "pybullet"
    interfaces: str = "llmpas"
    namespace: str = ""
    rmw: str = ""  # "": the user's RMW_IMPLEMENTATION (else ROS 2's default)
    use_sim_time: bool = False  # the client node's clock follows /clock (a simulated robot's)
    frames: Frames = field(default_factory=Frames)
    actions: Actions = field(default_factory=Actions)
    topics: Topics = field(default_factory=Topics)
    arm: Arm = field(default_factory=Arm)
    places: tuple[Place, ...] = ()
    furniture: tuple[Furniture, ...] = ()
    looks: tuple[Look, ...] = field(default_factory=_default_looks)
    source: str = ""  # the file it was read from

    def __post_init__(self) -> None:
        if self.interfaces not in INTERFACES:
            raise ValueError(f"interfaces: one of {', '.join(INTERFACES)}")
        if self.namespace:
            if not self.namespace.startswith("/"):
                raise ValueError("namespace: absolute, like /robot1")
            _name(self.namespace, "namespace")
        if self.rmw and not self.rmw.startswith("rmw_"):
            raise ValueError(f"rmw: an RMW implementation (rmw_...), not {self.rmw!r}")
        names = [p.name for p in self.places]
        if len(set(names)) != len(names):
            raise ValueError("places: duplicate names")

    @property
    def standard(self) -> bool:
        return self.interfaces == "standard"

    def look(self, camera: str) -> Look:
        for k in self.looks:
            if k.camera == camera:
                return k
        return Look(camera, "wrist_detections" if camera != "mast" else "detections")

    def place_of(self, x: float, y: float) -> str | None:
        for p in self.places:
            if p.contains(x, y):
                return p.name
        return None


# ---------------------------------------------------------------------- reading

T = TypeVar("T")


def _floats(raw: Any, key: str, n: int | None = None) -> tuple[float, ...]:
    if not isinstance(raw, list) or any(isinstance(v, bool) for v in raw):
        raise ProfileError(f"{key}: a list of numbers")
    try:
        out = tuple(float(v) for v in raw)
    except (TypeError, ValueError):
        raise ProfileError(f"{key}: a list of numbers") from None
    if n is not None and len(out) != n:
        raise ProfileError(f"{key}: {n} numbers")
    return out


def _build(kind: Callable[..., T], raw: Any, key: str, convert: Mapping[str, Any]) -> T:
    """``kind(**raw)`` with unknown keys refused and ``convert``'s fields converted."""
    if not isinstance(raw, dict):
        raise ProfileError(f"{key or 'the profile'}: a mapping")
    known = {f.name for f in fields(kind)}  # type: ignore[arg-type]
    for k in raw:
        if k not in known:
            raise ProfileError(f"{_at(key, k)}: unknown key (known: {', '.join(sorted(known))})")
    args: dict[str, Any] = {}
    for k, v in raw.items():
        if k in convert:
            args[k] = convert[k](v, _at(key, k))
        elif isinstance(v, (dict, list)):
            raise ProfileError(f"{_at(key, k)}: a single value")
        else:
            args[k] = v if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)
    try:
        return kind(**args)
    except (ValueError, TypeError) as e:
        text = str(e)
        if ":" in text and text.split(":", 1)[0] in known:
            raise ProfileError(_at(key, text)) from None
        raise ProfileError(f"{key or 'the profile'}: {text}") from None


def _at(key: str, child: str) -> str:
    return f"{key}.{child}" if key else child


def _qos(raw: Any, key: str) -> Qos:
    return _build(Qos, raw, key, {})


def _topic(raw: Any, key: str) -> Topic:
    if isinstance(raw, str):
        raw = {"name": raw}
    return _build(Topic, raw, key, {"qos": _qos})


def _list(item: Callable[[Any, str], T]) -> Callable[[Any, str], tuple[T, ...]]:
    def read(raw: Any, key: str) -> tuple[T, ...]:
        if not isinstance(raw, list):
            raise ProfileError(f"{key}: a list")
        return tuple(item(v, f"{key}[{i}]") for i, v in enumerate(raw))

    return read


def _names(raw: Any, key: str) -> tuple[str, ...]:
    if not isinstance(raw, list) or not all(isinstance(v, str) for v in raw):
        raise ProfileError(f"{key}: a list of names")
    return tuple(raw)


def _points(raw: Any, key: str) -> tuple[tuple[float, float], ...]:
    if not isinstance(raw, list):
        raise ProfileError(f"{key}: a list of [x, y] points")
    out = []
    for i, v in enumerate(raw):
        x, y = _floats(v, f"{key}[{i}]", 2)
        out.append((x, y))
    return tuple(out)


def _bool(raw: Any, key: str) -> bool:
    if not isinstance(raw, bool):
        raise ProfileError(f"{key}: true or false")
    return raw


def _floats_of(n: int | None) -> Callable[[Any, str], tuple[float, ...]]:
    return lambda raw, key: _floats(raw, key, n)


def parse(raw: Any, source: str = "") -> RobotProfile:
    """A profile from its YAML's data (:class:`ProfileError` names the key)."""
    if raw is None:
        raw = {}
    topics = {f.name: _topic for f in fields(Topics)}
    convert = {
        "frames": lambda v, k: _build(Frames, v, k, {}),
        "actions": lambda v, k: _build(Actions, v, k, {}),
        "topics": lambda v, k: _build(Topics, v, k, topics),
        "arm": lambda v, k: _build(Arm, v, k, {"joints": _names, "home": _floats_of(None)}),
        "places": _list(lambda v, k: _build(Place, v, k, {"footprint": _points})),
        "furniture": _list(
            lambda v, k: _build(Furniture, v, k, {"size": _floats_of(3), "pose": _floats_of(4)})
        ),
        "looks": _list(lambda v, k: _build(Look, v, k, {"joints": _floats_of(None)})),
        "use_sim_time": _bool,
    }
    if isinstance(raw, dict) and "source" in raw:
        raise ProfileError("source: unknown key")
    profile = _build(RobotProfile, raw, "", convert)
    return RobotProfile(**{**_fields(profile), "source": source})


def _fields(value: Any) -> dict[str, Any]:
    return {f.name: getattr(value, f.name) for f in fields(value)}


def load(path: str | Path) -> RobotProfile:
    """Read a profile file, or a shipped one by name (``pybullet``, ``pybullet-standard``).
    :class:`ProfileError` (``FILE: KEY: ...``) when it cannot be used."""
    import yaml

    p = Path(path)
    if not p.exists() and (PROFILES / f"{path}.yaml").is_file():
        p = PROFILES / f"{path}.yaml"
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise ProfileError(f"{p}: cannot read the robot profile ({e.strerror})") from None
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "YAML"
        raise ProfileError(f"{p}: {where}: not valid YAML") from None
    try:
        return parse(raw, str(p))
    except ProfileError as e:
        raise ProfileError(f"{p}: {e}") from None


def shipped() -> dict[str, Path]:
    return {f.stem: f for f in sorted(PROFILES.glob("*.yaml"))}


__all__ = [
    "PROFILES",
    "Actions",
    "Arm",
    "Frames",
    "Furniture",
    "Look",
    "Place",
    "ProfileError",
    "Qos",
    "RobotProfile",
    "Topic",
    "Topics",
    "load",
    "parse",
    "shipped",
]
