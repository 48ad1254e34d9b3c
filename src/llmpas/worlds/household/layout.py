"""The household's static layout: furniture, regions where objects can be, and their geometry.

A flat kitchen floor (metres, x right, y up). Objects rest in *regions*: table tops split into
parts, drawer interiors, appliances (sink, stove, microwave, fridge) and receptacle objects (a
bowl). Covers (an upside-down basket) stand on a region and hide what is under them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1


@dataclass(frozen=True)
class Furniture:
    name: str
    rect: Rect  # footprint on the floor: the base cannot drive through it (when solid)
    height: float
    solid: bool = True  # False for the floor itself: the base drives over it

    def center(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.rect
        return ((x0 + x1) / 2, (y0 + y1) / 2)


@dataclass(frozen=True)
class Region:
    """Where objects can rest.

    ``kind``: ``surface`` (a table part), ``container`` (drawer, microwave, fridge: visible and
    reachable only when open), ``appliance`` (sink, stove: an open surface that processes),
    ``receptacle`` (inside an object such as a bowl; its rect follows that object).
    ``process`` is what the region does to an object in it (clean/cook/heat/cool).
    ``capacity``: how many objects fit (None: as many as fit geometrically).
    """

    name: str
    kind: str
    furniture: str
    rect: Rect
    height: float
    process: str | None = None
    capacity: int | None = None
    openable: bool = False
    front: Rect | None = None  # the floor in front of its door: what stands there blocks it

    def __post_init__(self) -> None:
        if self.kind not in ("surface", "container", "appliance", "receptacle"):
            raise ValueError(f"region {self.name!r}: unknown kind {self.kind!r}")
        if self.capacity is not None and self.capacity < 1:
            raise ValueError(f"region {self.name!r}: capacity must be >= 1, got {self.capacity}")

    def center(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.rect
        return ((x0 + x1) / 2, (y0 + y1) / 2)

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        x0, y0, x1, y1 = self.rect
        return x0 + margin <= x <= x1 - margin and y0 + margin <= y <= y1 - margin


@dataclass(frozen=True)
class Layout:
    furniture: Mapping[str, Furniture]
    regions: Mapping[str, Region]
    size: tuple[float, float] = (6.0, 6.0)
    home: tuple[float, float, float] = (3.0, 2.5, math.pi / 2)  # base x, y, heading
    robot_radius: float = 0.3
    reach: float = 0.95  # arm reach from the base centre, metres
    view_range: float = 3.0  # camera range
    view_fov: float = math.radians(100)  # camera field of view

    def __post_init__(self) -> None:
        object.__setattr__(self, "furniture", MappingProxyType(dict(self.furniture)))
        object.__setattr__(self, "regions", MappingProxyType(dict(self.regions)))
        for r in self.regions.values():
            if r.furniture not in self.furniture:
                raise ValueError(f"region {r.name!r} is on unknown furniture {r.furniture!r}")

    def region(self, name: str) -> Region:
        try:
            return self.regions[name]
        except KeyError:
            raise KeyError(f"unknown region {name!r}; regions: {sorted(self.regions)}") from None

    def regions_of(self, furniture: str) -> tuple[Region, ...]:
        return tuple(r for r in self.regions.values() if r.furniture == furniture)

    def tables(self) -> tuple[str, ...]:
        return tuple(
            sorted(
                {
                    r.furniture
                    for r in self.regions.values()
                    if r.kind == "surface" and self.furniture[r.furniture].solid
                }
            )
        )

    def on_floor(self, region: str) -> bool:
        """``region`` is part of the floor (not on solid furniture)."""
        r = self.regions.get(region)
        return r is not None and not self.furniture[r.furniture].solid

    def solid(self) -> tuple[Furniture, ...]:
        """The furniture the base cannot drive through (everything but the floor)."""
        return tuple(f for f in self.furniture.values() if f.solid)

    def blocked_by(self, region: str, x: float, y: float, radius: float) -> bool:
        """A disc at (x, y) on the floor stands in front of ``region``'s door."""
        front = self.region(region).front
        if front is None:
            return False
        x0, y0, x1, y1 = front
        dx = max(x0 - x, 0.0, x - x1)
        dy = max(y0 - y, 0.0, y - y1)
        return math.hypot(dx, dy) < radius


def _halves(table: str, rect: Rect, height: float) -> dict[str, Region]:
    x0, y0, x1, y1 = rect
    mid = (x0 + x1) / 2
    return {
        f"{table}_left": Region(f"{table}_left", "surface", table, (x0, y0, mid, y1), height),
        f"{table}_right": Region(f"{table}_right", "surface", table, (mid, y0, x1, y1), height),
    }


FLOOR = "floor"
FLOOR_RECT: Rect = (0.55, 0.65, 5.15, 4.15)
"""The open floor between the furniture (a region only in houses with a floor)."""


def kitchen(floor: bool = False) -> Layout:
    """Two tables (two regions each), a counter with sink, stove and microwave, a fridge, and a
    cabinet of four drawers; with ``floor``, the open floor between them is a region too (where
    things fall, and where an obstacle can stand in front of a door).

    Capacities: a drawer, the sink and the fridge shelf hold two objects, the microwave one."""
    furniture = {
        "table1": Furniture("table1", (0.9, 4.2, 2.1, 5.0), 0.75),
        "table2": Furniture("table2", (3.9, 4.2, 5.1, 5.0), 0.75),
        "counter": Furniture("counter", (0.6, 0.0, 4.4, 0.6), 0.9),
        "fridge": Furniture("fridge", (5.2, 1.6, 6.0, 2.6), 1.8),
        "cabinet": Furniture("cabinet", (0.0, 1.6, 0.5, 3.6), 0.8),
    }
    regions: dict[str, Region] = {}
    regions |= _halves("table1", furniture["table1"].rect, 0.75)
    regions |= _halves("table2", furniture["table2"].rect, 0.75)
    regions["sink"] = Region(
        "sink", "appliance", "counter", (0.8, 0.05, 1.5, 0.55), 0.85, process="clean", capacity=2
    )
    regions["stove"] = Region(
        "stove", "appliance", "counter", (2.0, 0.05, 2.7, 0.55), 0.9, process="cook"
    )
    regions["microwave"] = Region(
        "microwave",
        "container",
        "counter",
        (3.3, 0.05, 4.2, 0.55),
        1.0,
        process="heat",
        capacity=1,
        openable=True,
        front=(3.3, 0.6, 4.2, 1.0),
    )
    regions["fridge"] = Region(
        "fridge",
        "container",
        "fridge",
        (5.25, 1.65, 5.95, 2.55),
        1.0,
        process="cool",
        capacity=2,
        openable=True,
        front=(4.8, 1.6, 5.2, 2.6),
    )
    for i in range(4):
        y0 = 1.6 + 0.5 * i
        regions[f"drawer{i + 1}"] = Region(
            f"drawer{i + 1}",
            "container",
            "cabinet",
            (0.05, y0 + 0.05, 0.45, y0 + 0.45),
            0.6,
            capacity=2,
            openable=True,
            front=(0.5, y0, 0.9, y0 + 0.5),
        )
    if floor:
        furniture[FLOOR] = Furniture(FLOOR, FLOOR_RECT, 0.0, solid=False)
        regions[FLOOR] = Region(FLOOR, "surface", FLOOR, FLOOR_RECT, 0.0)
    return Layout(furniture, regions)


@dataclass(frozen=True)
class ObjectSpec:
    """A movable object: its footprint radius, and whether it is a receptacle or a cover."""

    name: str
    radius: float = 0.05
    receptacle_capacity: int | None = None  # a bowl holds this many objects
    cover: bool = False  # an upside-down basket: hides what is under it
    properties: frozenset[str] = field(default_factory=frozenset)  # e.g. {"dirty"}
    looks_like: str | None = None  # a lookalike: a detector may take it for this object


def default_objects() -> dict[str, ObjectSpec]:
    return {
        "apple": ObjectSpec("apple", 0.05),
        "bread": ObjectSpec("bread", 0.07),
        "mug": ObjectSpec("mug", 0.05),
        "cube": ObjectSpec("cube", 0.03),
        "black_cube": ObjectSpec("black_cube", 0.03),
        "bowl": ObjectSpec("bowl", 0.09, receptacle_capacity=1),
        "basket": ObjectSpec("basket", 0.16, cover=True),
        "box": ObjectSpec("box", 0.15),  # a crate: put on the floor, it blocks doors
        "plate": ObjectSpec("plate", 0.09),
        "red_apple": ObjectSpec("red_apple", 0.05, looks_like="apple"),
    }
