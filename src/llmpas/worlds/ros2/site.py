"""A site file (``--site FILE``): what a robot's owner knows of the place, in the map frame.

A YAML file names the places (each a region: a ``box`` or a ``polygon`` with a ``height``; a
``surface`` or a ``container``, openable or not) with the base poses to ``reach`` it from and
to ``look`` at it from; the static ``furniture`` (collision boxes of the planning scene); the
object ``classes`` (a shape and a size, for grasping); the ``objects`` the robot is told of
(a class and a place, optionally where on it; none, or no place, is allowed); and ``tasks``
(a name and a goal over the places and objects)::

    frame: map
    places:
      table1:
        kind: surface                       # surface | container
        box: {center: [1.6, 0.0], size: [1.0, 1.5], height: 0.625}
        reach: [[0.85, 0.0, 0.0]]           # base poses (x, y, yaw) to reach it from
        look: [[0.9, 0.0, 0.0]]             # ... and to look at it from (default: reach)
    furniture:
      table1: {size: [1.0, 1.5, 0.625], pose: [1.6, 0.0, 0.3125, 0.0]}
    classes:
      cube: {shape: box, size: [0.05, 0.05, 0.05]}
    objects:
      cube: {class: cube, place: table1, at: [1.27, 0.15], colour: green}
    tasks:
      fetch: {goal: "(and (On cube table2))"}

Everything is parsed into frozen dataclasses validated in ``__post_init__``; a bad field is a
:class:`SiteError` whose text is ``FILE: KEY: what is wrong`` (the key a dotted path, like
``places.table1.reach``). Nothing here reads a simulator or a scenario.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

SITES = Path(__file__).resolve().parent / "sites"
KINDS = ("surface", "container")
SHAPES = ("box", "container", "lid")  # a solid box; an open box (a bowl); a plate with a knob
NAME = re.compile(r"^[a-z][a-z0-9_\-]*$")
T = TypeVar("T")


class SiteError(ValueError):
    """A site file that cannot be used: ``FILE: KEY: what is wrong``."""


def _check_name(name: str) -> None:
    if not NAME.match(name):
        raise ValueError(f"{name!r} is not a name (lower case letters, digits, _ and -)")


@dataclass(frozen=True)
class BasePose:
    """A base pose in the map frame: x, y (m) and yaw (rad)."""

    x: float
    y: float
    yaw: float

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.x, self.y, self.yaw)):
            raise ValueError("a base pose of finite numbers")


@dataclass(frozen=True)
class Region:
    """A place's region: a polygon (counter-clockwise or not) of ``points`` on the floor plane
    and the ``height`` of its surface (a container's: its floor)."""

    points: tuple[tuple[float, float], ...]
    height: float

    def __post_init__(self) -> None:
        if len(self.points) < 3:
            raise ValueError("at least three [x, y] points")
        if not 0.0 <= self.height <= 3.0:
            raise ValueError(f"height {self.height} out of [0, 3] m")
        if abs(self.area) < 1e-6:
            raise ValueError("a region of no area")

    @classmethod
    def box(cls, center: tuple[float, float], size: tuple[float, float], height: float,
            yaw: float = 0.0) -> Region:  # fmt: skip
        if min(size) <= 0:
            raise ValueError("size: two positive numbers")
        (cx, cy), (hx, hy) = center, (size[0] / 2, size[1] / 2)
        c, s = math.cos(yaw), math.sin(yaw)
        corners = ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
        points = tuple(
            (round(cx + c * dx - s * dy, 9), round(cy + s * dx + c * dy, 9)) for dx, dy in corners
        )
        return cls(points, height)

    @property
    def area(self) -> float:
        pts = self.points
        return 0.5 * sum(
            x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True)
        )

    def contains(self, x: float, y: float) -> bool:
        inside = False
        pts = self.points
        for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True):
            if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
                inside = not inside
        return inside

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        xs, ys = [p[0] for p in self.points], [p[1] for p in self.points]
        return (min(xs), min(ys), max(xs), max(ys))

    @property
    def axis_aligned(self) -> bool:
        """Whether the region is an axis-aligned rectangle (its bounds)."""
        x0, y0, x1, y1 = self.bounds
        return len(self.points) == 4 and abs(abs(self.area) - (x1 - x0) * (y1 - y0)) < 1e-6


@dataclass(frozen=True)
class SitePlace:
    """A named place: its region, a surface or a container, openable or not, and the base
    poses to reach it and to look at it from (at least one to reach it)."""

    name: str
    region: Region
    kind: str = "surface"
    openable: bool = False
    reach: tuple[BasePose, ...] = ()
    look: tuple[BasePose, ...] = ()

    def __post_init__(self) -> None:
        _check_name(self.name)
        if self.kind not in KINDS:
            raise ValueError(f"kind: one of {', '.join(KINDS)}")
        if not self.reach:
            raise ValueError("reach: no base pose to reach it from (give at least one [x, y, yaw])")
        if self.openable and self.kind != "container":
            raise ValueError("openable: only a container opens")

    @property
    def views(self) -> tuple[BasePose, ...]:
        """The poses to look at it from (its reach poses when none is given)."""
        return self.look or self.reach


@dataclass(frozen=True)
class Furniture:
    """A static collision box: its size and its centre pose (x, y, z, yaw) in the map."""

    name: str
    size: tuple[float, float, float]
    pose: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        _check_name(self.name)
        if len(self.size) != 3 or min(self.size) <= 0:
            raise ValueError("size: three positive numbers")
        if len(self.pose) != 4:
            raise ValueError("pose: [x, y, z, yaw]")


@dataclass(frozen=True)
class ObjectClass:
    """A kind of object: its shape (``box``, ``container``: an open box, ``lid``: a plate with
    a knob), its size (x, y, z in m) and whether the gripper takes it."""

    name: str
    shape: str
    size: tuple[float, float, float]
    graspable: bool = True

    def __post_init__(self) -> None:
        _check_name(self.name)
        if self.shape not in SHAPES:
            raise ValueError(f"shape: one of {', '.join(SHAPES)}")
        if len(self.size) != 3 or not all(0.005 <= v <= 2.0 for v in self.size):
            raise ValueError("size: three numbers in [0.005, 2] m")


@dataclass(frozen=True)
class ToldObject:
    """What the robot is told of an object: its class, and where it is (a place, optionally a
    point on it; no place: it exists, whereabouts unknown)."""

    name: str
    cls: str
    place: str = ""
    at: tuple[float, float] | None = None
    colour: str = ""  # a word the reasoner is told ("green"); "": none

    def __post_init__(self) -> None:
        _check_name(self.name)
        if self.at is not None and not self.place:
            raise ValueError("at: a point on a place; give the place too")


@dataclass(frozen=True)
class Task:
    """A task: a goal in the planner's language over the site's names."""

    name: str
    goal: str
    description: str = ""

    def __post_init__(self) -> None:
        _check_name(self.name)
        if not self.goal.strip().startswith("("):
            raise ValueError("goal: a formula like (and (On cube bowl))")


@dataclass(frozen=True)
class Site:
    """A site: places, furniture, object classes, told objects and tasks, in ``frame``."""

    name: str
    places: tuple[SitePlace, ...]
    furniture: tuple[Furniture, ...] = ()
    classes: tuple[ObjectClass, ...] = ()
    objects: tuple[ToldObject, ...] = ()
    tasks: tuple[Task, ...] = ()
    frame: str = "map"
    source: str = ""

    def __post_init__(self) -> None:
        if not self.places:
            raise ValueError("places: at least one place")
        names = [p.name for p in self.places] + [o.name for o in self.objects]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"objects: {dup[0]!r} names a place and an object")
        places = {p.name for p in self.places}
        classes = {c.name for c in self.classes}
        for o in self.objects:
            if o.cls not in classes:
                raise ValueError(f"objects.{o.name}.class: no class {o.cls!r} in classes")
            if o.place and o.place not in places:
                raise ValueError(f"objects.{o.name}.place: no place {o.place!r} in places")
            if o.at is not None and not self.place(o.place).region.contains(*o.at):
                raise ValueError(f"objects.{o.name}.at: {list(o.at)} is not on {o.place}")
        known = places | {o.name for o in self.objects}
        for t in self.tasks:
            for word in _names_in(t.goal):
                if word not in known:
                    raise ValueError(
                        f"tasks.{t.name}.goal: unknown place or object {word!r} "
                        f"(known: {', '.join(sorted(known))})"
                    )

    def place(self, name: str) -> SitePlace:
        for p in self.places:
            if p.name == name:
                return p
        raise KeyError(name)

    def cls(self, name: str) -> ObjectClass:
        for c in self.classes:
            if c.name == name:
                return c
        raise KeyError(name)

    def task(self, name: str) -> Task:
        for t in self.tasks:
            if t.name == name:
                return t
        known = ", ".join(t.name for t in self.tasks) or "none"
        raise KeyError(f"no task {name!r} in the site {self.source or self.name} (tasks: {known})")

    def place_of(self, x: float, y: float) -> str | None:
        for p in self.places:
            if p.region.contains(x, y):
                return p.name
        return None


def _names_in(goal: str) -> list[str]:
    """The arguments of a goal's atoms (the words after a predicate): ``(On cube bowl)``."""
    out: list[str] = []
    for atom in re.findall(r"\(\s*([A-Za-z][\w\-]*)((?:\s+[^\s()]+)+)\s*\)", goal):
        if atom[0].lower() in ("and", "or", "not"):
            continue
        out.extend(w for w in atom[1].split() if not w.startswith("?"))
    return out


# ---------------------------------------------------------------------- reading


def _mapping(raw: Any, key: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()
             ) -> dict[str, Any]:  # fmt: skip
    if not isinstance(raw, dict):
        raise SiteError(f"{key}: a mapping")
    for k in raw:
        if k not in allowed:
            raise SiteError(f"{key}.{k}: unknown key (known: {', '.join(allowed)})")
    for k in required:
        if k not in raw:
            raise SiteError(f"{key}.{k}: missing")
    return raw


def _number(raw: Any, key: str) -> float:
    if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
        raise SiteError(f"{key}: a number")
    return float(raw)


def _numbers(raw: Any, key: str, n: int) -> tuple[float, ...]:
    if not isinstance(raw, list) or len(raw) != n:
        raise SiteError(f"{key}: a list of {n} numbers")
    return tuple(_number(v, f"{key}[{i}]") for i, v in enumerate(raw))


def _text(raw: Any, key: str) -> str:
    if not isinstance(raw, str) or not raw.strip():
        raise SiteError(f"{key}: a non-empty string")
    return raw.strip()


def _named(raw: Any, key: str, item: Callable[[str, Any, str], T]) -> tuple[T, ...]:
    """A mapping of names to entries (or nothing)."""
    if raw is None:
        return ()
    if not isinstance(raw, dict):
        raise SiteError(f"{key}: a mapping of names to entries")
    return tuple(item(str(name), v, f"{key}.{name}") for name, v in raw.items())


def _made(factory: Callable[..., T], key: str, **args: Any) -> T:
    try:
        return factory(**args)
    except (ValueError, TypeError) as e:
        text = str(e)
        head = text.split(":", 1)[0]
        if ":" in text and " " not in head:
            return _raise(f"{key}.{text}")
        return _raise(f"{key}: {text}")


def _raise(text: str) -> Any:
    raise SiteError(text)


def _region(raw: dict[str, Any], key: str) -> Region:
    if ("box" in raw) == ("polygon" in raw):
        raise SiteError(f"{key}: a region: give box or polygon (with height), one of them")
    if "box" in raw:
        k = f"{key}.box"
        box = _mapping(raw["box"], k, ("center", "size", "height", "yaw"),
                       ("center", "size", "height"))  # fmt: skip
        center = _numbers(box["center"], f"{k}.center", 2)
        size = _numbers(box["size"], f"{k}.size", 2)
        height = _number(box["height"], f"{k}.height")
        yaw = _number(box.get("yaw", 0.0), f"{k}.yaw")
        try:
            return Region.box((center[0], center[1]), (size[0], size[1]), height, yaw)
        except ValueError as e:
            raise SiteError(f"{k}: {e}") from None
    if "height" not in raw:
        raise SiteError(f"{key}.height: missing (a polygon's surface height)")
    k = f"{key}.polygon"
    if not isinstance(raw["polygon"], list):
        raise SiteError(f"{k}: a list of [x, y] points")
    points = tuple(_numbers(v, f"{k}[{i}]", 2) for i, v in enumerate(raw["polygon"]))
    height = _number(raw["height"], f"{key}.height")
    try:
        return Region(tuple((p[0], p[1]) for p in points), height)
    except ValueError as e:
        raise SiteError(f"{k}: {e}") from None


def _poses(raw: Any, key: str) -> tuple[BasePose, ...]:
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise SiteError(f"{key}: a list of [x, y, yaw] base poses")
    return tuple(BasePose(*_numbers(v, f"{key}[{i}]", 3)) for i, v in enumerate(raw))


def _place(name: str, raw: Any, key: str) -> SitePlace:
    keys = ("kind", "openable", "box", "polygon", "height", "reach", "look")
    raw = _mapping(raw, key, keys)
    openable = raw.get("openable", False)
    if not isinstance(openable, bool):
        raise SiteError(f"{key}.openable: true or false")
    kind = raw.get("kind", "surface")
    if not isinstance(kind, str):
        raise SiteError(f"{key}.kind: one of {', '.join(KINDS)}")
    return _made(
        SitePlace,
        key,
        name=name,
        region=_region(raw, key),
        kind=kind,
        openable=openable,
        reach=_poses(raw.get("reach"), f"{key}.reach"),
        look=_poses(raw.get("look"), f"{key}.look"),
    )


def _furniture(name: str, raw: Any, key: str) -> Furniture:
    raw = _mapping(raw, key, ("size", "pose"), ("size", "pose"))
    size = _numbers(raw["size"], f"{key}.size", 3)
    pose = _numbers(raw["pose"], f"{key}.pose", 4)
    return _made(Furniture, key, name=name, size=size, pose=pose)


def _class(name: str, raw: Any, key: str) -> ObjectClass:
    raw = _mapping(raw, key, ("shape", "size", "graspable"), ("shape", "size"))
    graspable = raw.get("graspable", raw["shape"] != "container")
    if not isinstance(graspable, bool):
        raise SiteError(f"{key}.graspable: true or false")
    size = _numbers(raw["size"], f"{key}.size", 3)
    return _made(ObjectClass, key, name=name, shape=_text(raw["shape"], f"{key}.shape"),
                 size=size, graspable=graspable)  # fmt: skip


def _object(name: str, raw: Any, key: str) -> ToldObject:
    raw = _mapping(raw, key, ("class", "place", "at", "colour"), ("class",))
    colour = raw.get("colour")
    colour = "" if colour is None else _text(colour, f"{key}.colour")
    place = raw.get("place")
    place = "" if place is None else _text(place, f"{key}.place")
    at = raw.get("at")
    point = None if at is None else _numbers(at, f"{key}.at", 2)
    return _made(ToldObject, key, name=name, cls=_text(raw["class"], f"{key}.class"),
                 place=place, at=None if point is None else (point[0], point[1]),
                 colour=colour)  # fmt: skip


def _task(name: str, raw: Any, key: str) -> Task:
    raw = _mapping(raw, key, ("goal", "description"), ("goal",))
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise SiteError(f"{key}.description: a string")
    return _made(Task, key, name=name, goal=_text(raw["goal"], f"{key}.goal"),
                 description=description.strip())  # fmt: skip


TOP = ("name", "frame", "places", "furniture", "classes", "objects", "tasks")


def parse(raw: Any, source: str = "") -> Site:
    """A site from its YAML's data (:class:`SiteError` names the key)."""
    raw = _mapping(raw, "the site", TOP, ("places",))
    frame = raw.get("frame", "map")
    if not isinstance(frame, str) or not frame or frame.startswith("/"):
        raise SiteError("frame: a frame id, like map")
    name = raw.get("name") or (Path(source).stem if source else "site")
    places = _named(raw.get("places"), "places", _place)
    try:
        return Site(
            name=str(name),
            places=places,
            furniture=_named(raw.get("furniture"), "furniture", _furniture),
            classes=_named(raw.get("classes"), "classes", _class),
            objects=_named(raw.get("objects"), "objects", _object),
            tasks=_named(raw.get("tasks"), "tasks", _task),
            frame=frame,
            source=source,
        )
    except ValueError as e:
        if isinstance(e, SiteError):
            raise
        raise SiteError(str(e)) from None


def load(path: str | Path) -> Site:
    """Read a site file, or a shipped one by name (``house``). :class:`SiteError`
    (``FILE: KEY: ...``) when it cannot be used."""
    import yaml

    p = Path(path)
    if not p.exists() and (SITES / f"{path}.yaml").is_file():
        p = SITES / f"{path}.yaml"
    try:
        if not p.is_file():
            raise SiteError(f"{p}: no such site file")
        text = p.read_text(encoding="utf-8")
    except OSError as e:
        raise SiteError(f"{p}: cannot read the site file ({e.strerror})") from None
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "YAML"
        raise SiteError(f"{p}: {where}: not valid YAML") from None
    try:
        return parse(raw, str(p))
    except SiteError as e:
        raise SiteError(f"{p}: {e}") from None


def shipped() -> Mapping[str, Path]:
    return {f.stem: f for f in sorted(SITES.glob("*.yaml"))}


__all__ = [
    "SITES",
    "BasePose",
    "Furniture",
    "ObjectClass",
    "Region",
    "Site",
    "SiteError",
    "SitePlace",
    "Task",
    "ToldObject",
    "load",
    "parse",
    "shipped",
]
