"""The household's TRUE state: where every object really is. Only the simulator (and tests or
judges) read it; the robot learns about it through perception and skill outcomes.

Conventions:

* ``placements`` holds every object that is not in the hand. An object *inside* a receptacle
  object (a cube in the bowl) has the receptacle's name as its region (``Placement("bowl", x,
  y)``) and its x, y follow the receptacle. While the receptacle is held, its contents keep their
  last placement and are *carried*; they move with it when it is put down.
* An object *covered* by a cover (under the upside-down basket) has the cover's region and a
  position within the cover's radius. The cover's footprint stands for both.
* ``open`` has an entry for every openable region of the layout (closed unless said otherwise).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from llmpas.language.logic import Atom
from llmpas.worlds.household.household_values import BaseConf, Placement
from llmpas.worlds.household.layout import Layout, ObjectSpec, Rect

PROPERTIES = frozenset(
    {"dirty", "cleaned", "cooked", "heated", "cooled", "hot", "wet", "broken", "spilled"}
)
"""The object states the world knows."""

VISIBLE = PROPERTIES - {"hot"}
"""The states a camera sees (heat shows only when a skill fails because of it)."""

HIDDEN = frozenset({"frozen", "greasy", "waxed"})
"""Object states the world has but the planning domain does not model (no predicate names
them): no camera reports them, the robot never believes them, and a process they block fails
with the state named in its message (:data:`HIDDEN_BLOCKING`); another process removes them
(:data:`PROCESS_REMOVES`). Only what the robot is told can account for them."""

STATES = PROPERTIES | HIDDEN
"""Every object state a scenario may give an object."""

PROCESS_EFFECTS: Mapping[str, str] = MappingProxyType(
    {"clean": "cleaned", "cook": "cooked", "heat": "heated", "cool": "cooled"}
)
"""What each appliance process adds to the object's properties."""

PROCESS_REMOVES: Mapping[str, frozenset[str]] = MappingProxyType(
    {
        # rinsed under cold running water (which also thaws, washes grease and wax off)
        "clean": frozenset({"dirty", "hot", "spilled", "frozen", "greasy", "waxed"}),
        "dry": frozenset({"wet"}),  # wiped dry on a table
        "heat": frozenset({"frozen"}),  # thawed
    }
)
"""What a process takes away from the object's properties."""

BLOCKING: Mapping[str, Mapping[str, str]] = MappingProxyType(
    {
        "cook": MappingProxyType({"cooked": "it is already cooked: cooking again burns it"}),
        "cool": MappingProxyType(
            {
                "dirty": "only clean things can be cooled",
                "hot": "hot food must cool down before it goes into the fridge",
            }
        ),
        "heat": MappingProxyType({"spilled": "spilled food must be rinsed before heating"}),
    }
)
"""Process -> object state that makes it fail -> why (the failure's reason is the state)."""

HIDDEN_BLOCKING: Mapping[str, Mapping[str, str]] = MappingProxyType(
    {
        "cook": MappingProxyType(
            {"frozen": "frozen food cannot be cooked", "waxed": "waxed fruit is not cooked"}
        ),
        "cool": MappingProxyType({"greasy": "greasy things do not go into the fridge"}),
    }
)
"""Like :data:`BLOCKING`, for the :data:`HIDDEN` states (the message states the cause, never
the remedy)."""

ONE_AT_A_TIME = "one thing at a time"
"""Why a process fails in an appliance of a house whose rule is that it processes one object at
a time (``[house] one_at_a_time``) while another object is in it: a rule the domain does not
model (it knows only capacities), stated in the failure's message."""

EPS = 1e-9


# ------------------------------------------------------------------------------- geometry


def point_rect_distance(x: float, y: float, rect: Rect) -> float:
    """Distance from a point to an axis-aligned rectangle (0 inside it)."""
    x0, y0, x1, y1 = rect
    dx = max(x0 - x, 0.0, x - x1)
    dy = max(y0 - y, 0.0, y - y1)
    return math.hypot(dx, dy)


def _point_segment_distance(
    px: float, py: float, ax: float, ay: float, bx: float, by: float
) -> float:
    vx, vy = bx - ax, by - ay
    n2 = vx * vx + vy * vy
    t = 0.0 if n2 == 0.0 else max(0.0, min(1.0, ((px - ax) * vx + (py - ay) * vy) / n2))
    return math.hypot(px - (ax + t * vx), py - (ay + t * vy))


def _segments_cross(
    a: tuple[float, float], b: tuple[float, float], c: tuple[float, float], d: tuple[float, float]
) -> bool:
    def orient(p: tuple[float, float], q: tuple[float, float], r: tuple[float, float]) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    d1, d2 = orient(c, d, a), orient(c, d, b)
    d3, d4 = orient(a, b, c), orient(a, b, d)
    return d1 * d2 < 0 and d3 * d4 < 0


def segment_rect_distance(ax: float, ay: float, bx: float, by: float, rect: Rect) -> float:
    """Distance from the segment a-b to an axis-aligned rectangle (0 when they touch)."""
    if point_rect_distance(ax, ay, rect) == 0.0 or point_rect_distance(bx, by, rect) == 0.0:
        return 0.0
    x0, y0, x1, y1 = rect
    corners = ((x0, y0), (x1, y0), (x1, y1), (x0, y1))
    edges = tuple(zip(corners, corners[1:] + corners[:1], strict=True))
    if any(_segments_cross((ax, ay), (bx, by), c, d) for c, d in edges):
        return 0.0
    return min(
        point_rect_distance(ax, ay, rect),
        point_rect_distance(bx, by, rect),
        *(_point_segment_distance(cx, cy, ax, ay, bx, by) for cx, cy in corners),
    )


def base_collision(layout: Layout, x: float, y: float) -> str | None:
    """What the base footprint (a disc of ``layout.robot_radius``) at (x, y) collides with: a
    furniture name, ``"the wall"``, or None when it is free."""
    r = layout.robot_radius
    width, height = layout.size
    if not (r - EPS <= x <= width - r + EPS and r - EPS <= y <= height - r + EPS):
        return "the wall"
    for f in layout.solid():
        if point_rect_distance(x, y, f.rect) < r - EPS:
            return f.name
    return None


# ------------------------------------------------------------------------------- snapshot


@dataclass(frozen=True)
class StateSnapshot:
    """A frozen copy of a :class:`TrueState`, for tests and reports."""

    placements: Mapping[str, Placement]
    held: str | None
    covered: Mapping[str, str]
    inside: Mapping[str, str]
    open: Mapping[str, bool]
    properties: Mapping[str, frozenset[str]]
    base: BaseConf
    jammed: frozenset[str] = frozenset()

    def region_of(self, obj: str) -> str | None:
        """The region ``obj`` rests in (None when held or unknown)."""
        p = self.placements.get(obj)
        return p.region if p is not None else None

    def describe(self) -> tuple[str, ...]:
        """One line per fact, sorted: where each object is, what it is like, what is open."""
        lines = []
        for obj, p in sorted(self.placements.items()):
            extra = f" under {self.covered[obj]}" if obj in self.covered else ""
            props = sorted(self.properties.get(obj, frozenset()))
            tag = f" [{', '.join(props)}]" if props else ""
            lines.append(f"{obj} at {p}{extra}{tag}")
        if self.held is not None:
            lines.append(f"robot holds {self.held}")
        lines.extend(f"{c} is {'open' if o else 'closed'}" for c, o in sorted(self.open.items()))
        lines.append(f"robot base at {self.base}")
        return tuple(lines)


# ------------------------------------------------------------------------------- the state


@dataclass
class TrueState:
    """The mutable true state of the household (see the module docstring for conventions)."""

    layout: Layout
    specs: Mapping[str, ObjectSpec]
    base: BaseConf
    placements: dict[str, Placement] = field(default_factory=dict)
    held: str | None = None
    covered: dict[str, str] = field(default_factory=dict)
    inside: dict[str, str] = field(default_factory=dict)
    open: dict[str, bool] = field(default_factory=dict)
    properties: dict[str, set[str]] = field(default_factory=dict)
    held_from: Placement | None = None  # where the held object was taken from
    jammed: set[str] = field(default_factory=set)  # doors that do not open
    one_at_a_time: set[str] = field(default_factory=set)  # appliances: one object per process

    def __post_init__(self) -> None:
        for name, region in self.layout.regions.items():
            if region.openable:
                self.open.setdefault(name, False)
        for obj in self.objects:
            self.properties.setdefault(obj, set(self.spec(obj).properties))

    # ---------------------------------------------------------------------------- objects

    @property
    def objects(self) -> tuple[str, ...]:
        """Every object in the world (placed or held), sorted."""
        names = set(self.placements)
        if self.held is not None:
            names.add(self.held)
        return tuple(sorted(names))

    def spec(self, obj: str) -> ObjectSpec:
        try:
            return self.specs[obj]
        except KeyError:
            raise KeyError(f"unknown object {obj!r}; objects: {sorted(self.specs)}") from None

    def radius(self, obj: str) -> float:
        return self.spec(obj).radius

    def exists(self, obj: str) -> bool:
        return obj in self.placements or obj == self.held

    def is_receptacle(self, name: str) -> bool:
        """``name`` is a receptacle object present in the world (its name is then a region)."""
        spec = self.specs.get(name)
        return spec is not None and spec.receptacle_capacity is not None and self.exists(name)

    def is_cover(self, name: str) -> bool:
        spec = self.specs.get(name)
        return spec is not None and spec.cover and self.exists(name)

    def carried(self, obj: str) -> bool:
        """``obj`` is in the hand, or inside a receptacle that is carried."""
        seen: set[str] = set()
        while obj not in seen:
            if obj == self.held:
                return True
            seen.add(obj)
            container = self.inside.get(obj)
            if container is None:
                return False
            obj = container
        return False

    def position(self, obj: str) -> tuple[float, float] | None:
        """Where ``obj`` truly is on the floor plane (None when carried or absent)."""
        if self.carried(obj) or obj not in self.placements:
            return None
        p = self.placements[obj]
        return (p.x, p.y)

    def covers(self, cover: str) -> tuple[str, ...]:
        """The objects under ``cover``."""
        return tuple(sorted(o for o, c in self.covered.items() if c == cover))

    def contents(self, receptacle: str) -> tuple[str, ...]:
        return tuple(sorted(o for o, r in self.inside.items() if r == receptacle))

    def visible(self, obj: str) -> bool:
        """Not carried, not covered, and (inside a receptacle) the receptacle is visible. Closed
        containers are handled by what the camera can view, not here."""
        if not self.exists(obj) or self.carried(obj) or obj in self.covered:
            return False
        container = self.inside.get(obj)
        return container is None or self.visible(container)

    # ---------------------------------------------------------------------------- regions

    def regions(self) -> tuple[str, ...]:
        """Every region name: the layout's, then the receptacle objects present."""
        recs = sorted(o for o in self.objects if self.is_receptacle(o))
        return (*self.layout.regions, *recs)

    def is_region(self, name: str) -> bool:
        return name in self.layout.regions or self.is_receptacle(name)

    def objects_in(self, region: str) -> tuple[str, ...]:
        """The objects truly resting in ``region`` (covered ones included, held ones not)."""
        return tuple(sorted(o for o, p in self.placements.items() if p.region == region))

    def capacity(self, region: str) -> int | None:
        if region in self.layout.regions:
            return self.layout.regions[region].capacity
        spec = self.specs.get(region)
        return spec.receptacle_capacity if spec is not None else None

    def occupied(self, region: str) -> bool:
        """The true contents of ``region`` fill its capacity (never for unlimited regions)."""
        cap = self.capacity(region)
        return cap is not None and len(self.objects_in(region)) >= cap

    def overlapping(
        self, region: str, x: float, y: float, radius: float, ignore: Iterable[str] = ()
    ) -> tuple[str, ...]:
        """The objects in ``region`` whose footprints overlap a disc at (x, y). Covered objects
        are left out: the cover's footprint stands for them."""
        skip = set(ignore)
        hits = []
        for obj in self.objects_in(region):
            if obj in skip or obj in self.covered:
                continue
            p = self.placements[obj]
            if math.hypot(p.x - x, p.y - y) < radius + self.radius(obj) - EPS:
                hits.append(obj)
        return tuple(hits)

    def free_at(
        self, region: str, x: float, y: float, radius: float, ignore: Iterable[str] = ()
    ) -> bool:
        """No other object's footprint in ``region`` overlaps a disc of ``radius`` at (x, y)."""
        return not self.overlapping(region, x, y, radius, ignore)

    def fits(self, region: str, x: float, y: float, radius: float) -> bool:
        """A disc of ``radius`` at (x, y) lies in ``region``: inside its rectangle, or (for a
        receptacle object) within the receptacle's rim."""
        if region in self.layout.regions:
            return self.layout.regions[region].contains(x, y, margin=radius - EPS)
        if self.is_receptacle(region):
            at = self.position(region)
            if at is None:
                return False
            return math.hypot(x - at[0], y - at[1]) <= self.radius(region) - radius + EPS
        return False

    def inaccessible_reason(self, region: str) -> str | None:
        """Why objects cannot be put into or taken from ``region`` (None: they can)."""
        if region in self.layout.regions:
            if self.layout.regions[region].openable and not self.open.get(region, False):
                return f"{region} is closed"
            return None
        if not self.is_receptacle(region):
            return f"{region} is not a region"
        if self.carried(region):
            return f"{region} is held"
        if region in self.covered:
            return f"{region} is covered by {self.covered[region]}"
        return self.inaccessible_reason(self.placements[region].region)

    def accessible(self, region: str) -> bool:
        """A container must be open; a receptacle object must not be covered (nor carried, nor
        in a closed container)."""
        return self.inaccessible_reason(region) is None

    # ---------------------------------------------------------------------------- changes

    def take(self, obj: str) -> None:
        """``obj`` goes into the hand. Objects under it (a cover) stay where they are, uncovered;
        objects inside it (a receptacle) are carried along."""
        if self.held is not None:
            raise ValueError(f"cannot take {obj}: the hand holds {self.held}")
        self.held_from = self.placements.pop(obj)
        self.held = obj
        self.inside.pop(obj, None)
        self.covered.pop(obj, None)
        for o in self.covers(obj):
            del self.covered[o]

    def put(self, obj: str, place: Placement, under: str | None = None) -> None:
        """Put ``obj`` (held, placed elsewhere, or new) at ``place``; into a receptacle when the
        region names one, and under ``under`` when given. Its contents follow it."""
        if obj == self.held:
            before = self.held_from
            self.held = None
            self.held_from = None
        else:
            before = self.placements.get(obj)
            if obj not in self.placements:
                self.properties.setdefault(obj, set(self.spec(obj).properties))
            if self.is_cover(obj) and before is not None:
                for o in self.covers(obj):  # a cover lifted away uncovers what was under it
                    del self.covered[o]
        self.placements[obj] = place
        if place.region in self.layout.regions:
            self.inside.pop(obj, None)
        else:
            self.inside[obj] = place.region
        if under is not None:
            self.covered[obj] = under
        else:
            self.covered.pop(obj, None)
        if before is not None:
            dx, dy = place.x - before.x, place.y - before.y
            self._shift_contents(obj, dx, dy)

    def _shift_contents(self, receptacle: str, dx: float, dy: float) -> None:
        for o in self.contents(receptacle):
            p = self.placements[o]
            self.placements[o] = Placement(p.region, p.x + dx, p.y + dy)
            self._shift_contents(o, dx, dy)

    def snapshot(self) -> StateSnapshot:
        return StateSnapshot(
            placements=MappingProxyType(dict(self.placements)),
            held=self.held,
            covered=MappingProxyType(dict(self.covered)),
            inside=MappingProxyType(dict(self.inside)),
            open=MappingProxyType(dict(self.open)),
            properties=MappingProxyType({o: frozenset(p) for o, p in self.properties.items()}),
            base=self.base,
            jammed=frozenset(self.jammed),
        )

    def blockers(self, region: str) -> tuple[str, ...]:
        """The objects standing on the floor in front of ``region``'s door."""
        return tuple(
            o
            for o, p in sorted(self.placements.items())
            if self.layout.on_floor(p.region)
            and not self.carried(o)
            and self.layout.blocked_by(region, p.x, p.y, self.radius(o))
        )


def true_facts(state: TrueState | StateSnapshot) -> frozenset[Atom]:
    """The true state as facts in the planning domain's words, for the truth judge
    (:func:`llmpas.worlds.api.holds`): ``(on O R)`` for every object resting in region R (not
    the held one), ``(holding O)``, ``(open R)`` for every open region and ``(S O)`` for every
    state S of O (hidden ones too)."""
    facts = {Atom("on", (o, p.region)) for o, p in state.placements.items() if o != state.held}
    if state.held is not None:
        facts.add(Atom("holding", (state.held,)))
    facts |= {Atom("open", (r,)) for r, is_open in state.open.items() if is_open}
    facts |= {Atom(s, (o,)) for o, states in state.properties.items() for s in states}
    return frozenset(facts)
