"""Household scenarios: a true initial state, what the robot believes, a goal, noise and the
anomalies to inject, read from TOML files.

Format (every table and field is checked; unknown fields are errors)::

    name = "object-loss-table"          # required
    description = "free text"           # optional
    seed = 7                            # optional integer (default 0): seed for the world's rng

    [noise]                             # optional; every field defaults to 0
    pose_sigma = 0.005                  # m: Gaussian noise of detected object positions
    base_sigma = 0.01                   # m: odometry noise of the base after each move_base
                                        #    (the heading gets the same sigma in radians)
    miss_prob = 0.05                    # probability that a visible object is not detected
    slip_prob = 0.0                     # probability that a grasp which would succeed slips

    [[noise.confuse]]                   # optional: the detector takes a lookalike for another
    object = "red_apple"                #   object: every detection of red_apple is reported as
    as = "apple"                        #   apple (with probability prob, default 1); grasping
    prob = 1.0                          #   "apple" there takes the red_apple

    [house]                             # optional: the house beyond the default kitchen
    floor = true                        # the open floor is a region ("floor"): things lie there,
                                        #   and one standing in front of a door blocks it
    jammed = ["drawer2"]                # doors that do not open (the robot does not know it
                                        #   unless [belief] jammed says so)
    one_at_a_time = ["sink"]            # appliances that process one object at a time: with
                                        #   another object in them the process fails (a house
                                        #   rule the domain does not model: no belief fact)

    [[noise.displace]]                  # optional: tolerable disturbances (recoverable by
    kind = "slip"                       #   resampling): the Nth grasp that would otherwise
    attempt = 1                         #   succeed slips (here: the first)

    [[noise.displace]]
    kind = "nudge"                      # an object slides by (dx, dy) within its region
    object = "cube"                     #   (at most 0.1 m; skipped at run time if it would
    dx = 0.02                           #   leave the region or overlap something)
    dy = 0.0
    after = { skill = "move_base", count = 1 }

    [[objects]]                         # the TRUE initial state; only listed objects exist
    name = "cube"                       # an object of the catalogue (layout.default_objects)
    region = "table1_right"             # a layout region, or a receptacle object ("bowl")
    x = 1.8                             # m; the whole footprint must lie in the region
    y = 4.45
    properties = ["dirty"]              # optional: dirty, cleaned, cooked, heated, cooled, hot,
                                        #   wet, broken, spilled (default: the catalogue's)
                                        #   cooked: not cooked again; hot: not into the fridge
                                        #   (rinse it in the sink); spilled: rinse before heating;
                                        #   wet: dry it on a table before a drawer; broken: it
                                        #   cannot be picked up. hot is not visible.
                                        #   Also frozen (not cooked), greasy (not into the
                                        #   fridge), waxed (not cooked): states the domain does
                                        #   not model (state.HIDDEN), never seen nor believed;
                                        #   rinsing removes them, heating thaws
    # instead of region/x/y:
    # under = "basket"                  # hidden under a cover; region and x, y default to the
    #                                   #   cover's (x, y must stay within the cover's rim)
    # inside = "bowl"                   # in a receptacle object; same as region = "bowl";
    #                                   #   x, y default to the receptacle's

    [open]                              # optional: openable region -> bool (default: closed)
    drawer2 = false

    [robot]                             # optional: the start pose (default: layout.home)
    x = 3.0
    y = 2.5
    theta = 1.5707963267948966          # radians

    [belief]                            # optional: what the robot believes at the start;
    [[belief.objects]]                  #   by default exactly the true initial state
    name = "cube"                       # override one object's location (region/x/y, under,
    region = "table1_left"              #   inside) and/or its properties; or
    x = 1.2                             #   unknown = true: the robot knows the object exists
    y = 4.5                             #   but not where it is; or
                                        #   absent = true: the robot does not know of it at all
    [belief.open]                       # override what the robot believes is open
    drawer2 = false
    # in [belief]: searched = ["table1_left", "drawer1"]   places already searched (in vain)
    #              jammed = ["drawer2"]                    doors the robot knows are jammed

    [task]
    goal = "(and (On cube bowl))"       # PDDL text; predicates On/2, Holding/1, Scanned/1,
                                        #   Cleaned/1, Cooked/1, Heated/1, Cooled/1 are checked
                                        #   for arity and known object/region names

    [[events]]                          # anomalies injected into the TRUE state
    after = { skill = "move_base", count = 1 }   # fires inside the Nth successful call of
    type = "move"                       #   that skill (move_base, move_arm, grasp, release,
    object = "cube"                     #   open, close, process, look)
    region = "table2_right"             # move: to a region (x, y optional: its centre), or
    x = 4.8                             #   into = "bowl" (a receptacle or a region), or
    y = 4.5                             #   under = "basket" (a cover: at its centre)
    # type = "occupy"                   # put an object (possibly one not yet in the world,
    #                                   #   e.g. black_cube) into a region or receptacle:
    #                                   #   region/into, x, y as for move
    # type = "set_property" / "clear_property"   with  property = "dirty"

Events and nudges that cannot apply when they fire (the target is full, the spot is taken, the
object is gone) are skipped; the world logs either outcome.

Read files with :func:`load_scenario` (or :func:`builtin_scenario` for the shipped ones in
``scenarios/``), or parsed data with :meth:`Scenario.from_dict`. Errors are
:class:`ScenarioError` (a ``ValueError``) with one line naming the file and the field, e.g.
``scenarios/x.toml: objects[2].region: unknown region 'tabel1'; regions: ...``. Array indices
are 0-based. A scenario is either fully loaded or not at all.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from llmpas.errors import InputError
from llmpas.fields import Fields, show
from llmpas.inputs import read_toml
from llmpas.language.errors import PddlSyntaxError
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.worlds.household.layout import Layout, ObjectSpec, default_objects, kitchen
from llmpas.worlds.household.state import HIDDEN, STATES, TrueState, base_collision
from llmpas.worlds.household.values import BaseConf, Placement

SKILLS = ("move_base", "move_arm", "grasp", "release", "open", "close", "process", "look")
EVENT_TYPES = ("move", "occupy", "set_property", "clear_property")
DISTURBANCE_KINDS = ("slip", "nudge")
GOAL_PREDICATES: Mapping[str, int] = MappingProxyType(
    {
        "on": 2,
        "holding": 1,
        "scanned": 1,
        "cleaned": 1,
        "cooked": 1,
        "heated": 1,
        "cooled": 1,
    }
)
MAX_NUDGE = 0.1
SCENARIO_DIR = Path(__file__).with_name("scenarios")


class ScenarioError(InputError):
    """A scenario file that cannot be loaded: ``file: field: message`` on one line."""


# ----------------------------------------------------------------------------------- values


@dataclass(frozen=True)
class Trigger:
    """Fires inside the ``count``-th successful call of ``skill``."""

    skill: str
    count: int

    def __str__(self) -> str:
        return f"after {self.skill} #{self.count}"


@dataclass(frozen=True)
class Disturbance:
    """A tolerable disturbance: ``slip`` (the ``attempt``-th grasp that would succeed slips) or
    ``nudge`` (``object`` slides by ``dx``, ``dy`` when ``after`` fires)."""

    kind: str
    attempt: int = 1
    object: str | None = None
    dx: float = 0.0
    dy: float = 0.0
    after: Trigger | None = None


@dataclass(frozen=True)
class Confusion:
    """The detector reports ``object`` as ``seen_as`` (a lookalike), with probability ``prob``."""

    object: str
    seen_as: str
    prob: float = 1.0

    def __post_init__(self) -> None:
        if self.object == self.seen_as:
            raise ValueError(f"{self.object} cannot be confused with itself")
        if not 0.0 <= self.prob <= 1.0:
            raise ValueError(f"prob must be in [0, 1], got {self.prob}")


@dataclass(frozen=True)
class Noise:
    pose_sigma: float = 0.0
    base_sigma: float = 0.0
    miss_prob: float = 0.0
    slip_prob: float = 0.0
    displace: tuple[Disturbance, ...] = ()
    confuse: tuple[Confusion, ...] = ()


@dataclass(frozen=True)
class ObjectInit:
    """An object of the true initial state."""

    name: str
    placement: Placement
    under: str | None = None
    inside: str | None = None
    properties: frozenset[str] = frozenset()


@dataclass(frozen=True)
class BeliefObject:
    """What the robot believes about one object at the start (``placement`` None: it does not
    know where the object is)."""

    name: str
    placement: Placement | None
    under: str | None = None
    inside: str | None = None
    properties: frozenset[str] = frozenset()


@dataclass(frozen=True)
class InitialBelief:
    """The robot's belief at the start: the objects it knows of (in scenario order) and which
    containers it believes open (every openable region has an entry)."""

    objects: tuple[BeliefObject, ...]
    open: Mapping[str, bool]
    searched: tuple[str, ...] = ()  # places already searched before the anomaly
    jammed: tuple[str, ...] = ()  # doors the robot knows do not open

    def __post_init__(self) -> None:
        object.__setattr__(self, "open", MappingProxyType(dict(self.open)))

    def get(self, name: str) -> BeliefObject | None:
        return next((o for o in self.objects if o.name == name), None)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects)

    def places(self) -> dict[str, Placement | None]:
        """Object -> believed placement (None: known to exist, whereabouts unknown)."""
        return {o.name: o.placement for o in self.objects}

    def open_regions(self) -> tuple[str, ...]:
        return tuple(sorted(r for r, is_open in self.open.items() if is_open))

    def properties(self) -> dict[str, frozenset[str]]:
        return {o.name: o.properties for o in self.objects if o.properties}


@dataclass(frozen=True)
class Event:
    """An anomaly injected into the true state when ``after`` fires.

    ``move``/``occupy``: ``object`` goes to ``region`` (a layout region or a receptacle object)
    at (``x``, ``y``) (None: the region's centre or the receptacle's position), or under the
    cover ``under`` (at its centre). ``set_property``/``clear_property``: ``property``.
    """

    after: Trigger
    type: str
    object: str
    region: str | None = None
    x: float | None = None
    y: float | None = None
    under: str | None = None
    property: str | None = None

    def describe(self) -> str:
        if self.type in ("set_property", "clear_property"):
            verb = "becomes" if self.type == "set_property" else "is no longer"
            return f"{self.object} {verb} {self.property}"
        if self.under is not None:
            return f"{self.object} is moved under {self.under}"
        at = (
            f" at ({self.x:.2f}, {self.y:.2f})" if self.x is not None and self.y is not None else ""
        )
        verb = "is moved to" if self.type == "move" else "now occupies"
        return f"{self.object} {verb} {self.region}{at}"


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    seed: int
    noise: Noise
    objects: tuple[ObjectInit, ...]
    open: Mapping[str, bool]  # every openable region of the layout
    robot: BaseConf
    belief: InitialBelief
    goal: str
    events: tuple[Event, ...] = ()
    specs: Mapping[str, ObjectSpec] = field(default_factory=dict)  # objects that can exist
    source: str = "<scenario>"
    layout: Layout = field(default_factory=kitchen, repr=False)  # with a floor if [house] says
    jammed: tuple[str, ...] = ()  # doors that do not open
    one_at_a_time: tuple[str, ...] = ()  # appliances that process one object at a time

    def __post_init__(self) -> None:
        object.__setattr__(self, "open", MappingProxyType(dict(self.open)))
        object.__setattr__(self, "specs", MappingProxyType(dict(self.specs)))

    @classmethod
    def from_dict(
        cls,
        data: Mapping[str, Any],
        *,
        source: str = "<scenario>",
        layout: Layout | None = None,
        catalogue: Mapping[str, ObjectSpec] | None = None,
    ) -> Scenario:
        """Check and build a scenario from parsed TOML (``source`` names it in errors)."""
        house = data.get("house", {}) if isinstance(data, Mapping) else {}
        floor = isinstance(house, Mapping) and house.get("floor") is True
        parser = _Parser(source, layout or kitchen(floor=floor), catalogue or default_objects())
        return parser.scenario(data)

    def object(self, name: str) -> ObjectInit:
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(f"{self.source}: no object {name!r}; objects: {self.object_names}")

    @property
    def object_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects)

    def initial_state(self, layout: Layout | None = None) -> TrueState:
        """A fresh TrueState of the initial situation."""
        state = TrueState(layout or self.layout, self.specs, self.robot)
        _fill(state, self.objects)
        state.open.update(self.open)
        state.jammed.update(self.jammed)
        state.one_at_a_time.update(self.one_at_a_time)
        return state


def _fill(state: TrueState, objects: tuple[ObjectInit, ...]) -> None:
    """Place ``objects`` (plain ones first: covers and receptacles before what they hold)."""

    def order(o: ObjectInit) -> int:
        return 2 if o.inside is not None else 1 if o.under is not None else 0

    for o in sorted(objects, key=order):
        state.put(o.name, o.placement, under=o.under)
        state.properties[o.name] = set(o.properties)


def load_scenario(
    path: str | Path,
    *,
    layout: Layout | None = None,
    catalogue: Mapping[str, ObjectSpec] | None = None,
) -> Scenario:
    """Read and check a scenario file."""
    source = str(path)
    try:
        data = read_toml(path, "scenario file")
    except InputError as e:
        raise ScenarioError(str(e)) from None
    return Scenario.from_dict(data, source=source, layout=layout, catalogue=catalogue)


def builtin_scenarios() -> tuple[str, ...]:
    """The names of the scenario files shipped with the package."""
    return tuple(sorted(p.stem for p in SCENARIO_DIR.glob("*.toml")))


def builtin_scenario(name: str, *, layout: Layout | None = None) -> Scenario:
    """Load a shipped scenario by name (``nominal``, ``object-loss-table``, ...)."""
    path = SCENARIO_DIR / f"{name}.toml"
    if not path.is_file():
        raise ScenarioError(f"unknown scenario {name!r}; scenarios: {_names(builtin_scenarios())}")
    return load_scenario(path, layout=layout)


# ----------------------------------------------------------------------------------- parsing


def _names(names: Any) -> str:
    """A sorted, comma-separated list of names (or "none")."""
    return ", ".join(sorted(names)) or "none"


_fmt = show


class _Parser(Fields):
    """The scenario's fields: the shared TOML readers (:class:`~llmpas.fields.Fields`) and the
    household's own (properties, catalogue objects, places, events, ...)."""

    def __init__(self, source: str, layout: Layout, catalogue: Mapping[str, ObjectSpec]) -> None:
        super().__init__(source, ScenarioError)
        self.layout = layout
        self.catalogue = catalogue

    # ------------------------------------------------------------------------ field readers

    def properties(self, value: Any, where: str) -> frozenset[str]:
        out = set()
        for i, p in enumerate(self.array(value, where)):
            name = self.string(p, f"{where}[{i}]")
            if name not in STATES:
                raise self.fail(
                    f"{where}[{i}]", f"unknown property {name!r}; properties: {_names(STATES)}"
                )
            out.add(name)
        return frozenset(out)

    def catalogue_object(self, value: Any, where: str) -> str:
        name = self.string(value, where)
        if name not in self.catalogue:
            raise self.fail(where, f"unknown object {name!r}; objects: {_names(self.catalogue)}")
        return name

    # ------------------------------------------------------------------------------ scenario

    def scenario(self, data: Mapping[str, Any]) -> Scenario:
        top = self.table(
            data,
            "",
            (
                "name",
                "description",
                "seed",
                "noise",
                "objects",
                "open",
                "robot",
                "belief",
                "task",
                "events",
                "house",
            ),
        )
        for key in ("name", "objects", "task"):
            if key not in top:
                raise self.fail(key, "missing (required)")
        name = self.string(top["name"], "name")
        description = top.get("description", "")
        if not isinstance(description, str):
            raise self.fail("description", f"must be a string, got {_fmt(description)}")
        seed = self.integer(top.get("seed", 0), "seed")

        raw_objects = self.array(top["objects"], "objects")
        if not raw_objects:
            raise self.fail("objects", "must list at least one object")
        entries = [
            (f"objects[{i}]", self.table(o, f"objects[{i}]", _OBJECT_FIELDS))
            for i, o in enumerate(raw_objects)
        ]
        names = self.object_names(entries)
        event_objects = self.event_objects(top.get("events", []))
        specs = {n: self.catalogue[n] for n in (*names, *event_objects)}

        truth = TrueState(self.layout, specs, BaseConf(*self.layout.home))
        resolved = self.place_objects(entries, truth)
        objects = tuple(
            ObjectInit(r.name, r.placement, r.under, r.inside, r.properties)
            for r in resolved
            if r.placement is not None
        )
        jammed, one_at_a_time = self.house(top.get("house", {}))
        open_ = self.open_table(top.get("open", {}), "open")
        for r in jammed:
            if open_[r]:
                raise self.fail("house.jammed", f"{r} is jammed: it cannot be open")
        robot = self.robot(top.get("robot", {}))
        belief = self.belief(top.get("belief", {}), entries, specs, open_)
        noise = self.noise(top.get("noise", {}), names)
        events = self.events(top.get("events", []), names, truth)
        goal = self.goal(top["task"], (*names, *event_objects))
        return Scenario(
            name=name,
            description=description,
            seed=seed,
            noise=noise,
            objects=objects,
            open=open_,
            robot=robot,
            belief=belief,
            goal=goal,
            events=events,
            specs=specs,
            source=self.source,
            layout=self.layout,
            jammed=jammed,
            one_at_a_time=one_at_a_time,
        )

    def house(self, value: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """The jammed doors and the appliances that process one object at a time."""
        t = self.table(value, "house", ("floor", "jammed", "one_at_a_time"))
        self.boolean(t.get("floor", False), "house.floor")  # read before parsing (the layout)
        jammed = self.containers(t.get("jammed", []), "house.jammed")
        where = "house.one_at_a_time"
        appliances = sorted(n for n, r in self.layout.regions.items() if r.process)
        alone: list[str] = []
        for i, raw in enumerate(self.array(t.get("one_at_a_time", []), where)):
            name = self.string(raw, f"{where}[{i}]")
            if name not in appliances:
                raise self.fail(
                    f"{where}[{i}]",
                    f"{name!r} is not an appliance; appliances: {_names(appliances)}",
                )
            if name not in alone:
                alone.append(name)
        return jammed, tuple(alone)

    def containers(self, value: Any, where: str) -> tuple[str, ...]:
        openable = sorted(n for n, r in self.layout.regions.items() if r.openable)
        out: list[str] = []
        for i, raw in enumerate(self.array(value, where)):
            name = self.string(raw, f"{where}[{i}]")
            if name not in openable:
                raise self.fail(
                    f"{where}[{i}]", f"{name!r} is not a door; containers: {_names(openable)}"
                )
            if name not in out:
                out.append(name)
        return tuple(out)

    def places(self, value: Any, where: str, covers: tuple[str, ...]) -> tuple[str, ...]:
        drawers = [n for n, r in self.layout.regions.items() if r.kind != "receptacle"]
        known = {*drawers, *covers}
        out: list[str] = []
        for i, raw in enumerate(self.array(value, where)):
            name = self.string(raw, f"{where}[{i}]")
            if name not in known:
                raise self.fail(f"{where}[{i}]", f"unknown place {name!r}; places: {_names(known)}")
            if name not in out:
                out.append(name)
        return tuple(out)

    def object_names(self, entries: list[tuple[str, Mapping[str, Any]]]) -> tuple[str, ...]:
        names: list[str] = []
        for where, t in entries:
            if "name" not in t:
                raise self.fail(f"{where}.name", "missing (required)")
            name = self.catalogue_object(t["name"], f"{where}.name")
            if name in names:
                raise self.fail(f"{where}.name", f"object {name!r} is listed twice")
            names.append(name)
        return tuple(names)

    def event_objects(self, raw: Any) -> tuple[str, ...]:
        """Objects that only enter the world through ``occupy`` events (checked later)."""
        out: list[str] = []
        if isinstance(raw, list):
            for e in raw:
                if isinstance(e, Mapping) and e.get("type") == "occupy":
                    obj = e.get("object")
                    if isinstance(obj, str) and obj in self.catalogue and obj not in out:
                        out.append(obj)
        return tuple(out)

    # ------------------------------------------------------------------------------- objects

    def place_objects(
        self, entries: list[tuple[str, Mapping[str, Any]]], state: TrueState, belief: bool = False
    ) -> list[BeliefObject]:
        """Check object entries and put them into ``state``: plain objects first, then those
        under covers, then those inside receptacles. Returns them in entry order (a
        BeliefObject without placement for ``unknown = true``)."""
        by_name = {str(t["name"]): t for _, t in entries}
        receptacles = {n for n in by_name if self.catalogue[n].receptacle_capacity is not None}
        covers = {n for n in by_name if self.catalogue[n].cover}

        def stage(entry: tuple[str, Mapping[str, Any]]) -> int:
            t = entry[1]
            if t.get("inside") is not None or t.get("region") in receptacles:
                return 2
            return 1 if t.get("under") is not None else 0

        out: dict[str, BeliefObject] = {}
        for where, t in sorted(entries, key=stage):
            name = str(t["name"])
            spec = self.catalogue[name]
            props = (
                self.properties(t["properties"], f"{where}.properties")
                if "properties" in t
                else spec.properties
            )
            if belief:  # states the domain does not model are never believed
                props = props - HIDDEN
            if belief and self.boolean(t.get("unknown", False), f"{where}.unknown"):
                if any(k in t for k in _LOCATION_FIELDS):
                    raise self.fail(
                        f"{where}.unknown", "an object of unknown location takes no region/x/y"
                    )
                out[name] = BeliefObject(name, None, properties=props)
                continue
            region, under, inside = self.relation(where, t, spec, by_name, receptacles, covers)
            placement = self.locate(where, t, spec, region, under, inside, state, receptacles)
            self.check_room(where, spec, placement, under, inside, state)
            state.put(name, placement, under=under)
            state.properties[name] = set(props)
            out[name] = BeliefObject(name, placement, under, inside, props)
        return [out[str(t["name"])] for _, t in entries if str(t["name"]) in out]

    def relation(
        self,
        where: str,
        t: Mapping[str, Any],
        spec: ObjectSpec,
        by_name: Mapping[str, Any],
        receptacles: set[str],
        covers: set[str],
    ) -> tuple[str | None, str | None, str | None]:
        """The entry's region, cover and receptacle, checked against each other."""
        region = self.string(t["region"], f"{where}.region") if "region" in t else None
        under = self.string(t["under"], f"{where}.under") if "under" in t else None
        inside = self.string(t["inside"], f"{where}.inside") if "inside" in t else None
        if under is not None:
            if under not in covers:
                what = "is not a cover" if under in by_name else "is not in the scenario"
                raise self.fail(
                    f"{where}.under", f"unknown cover {under!r} ({what}); covers: {_names(covers)}"
                )
            if spec.cover:
                raise self.fail(f"{where}.under", f"{spec.name} is a cover: it cannot be under one")
        if inside is not None:
            if inside not in receptacles:
                what = "is not a receptacle" if inside in by_name else "is not in the scenario"
                raise self.fail(
                    f"{where}.inside",
                    f"unknown receptacle {inside!r} ({what}); receptacles: {_names(receptacles)}",
                )
            if region is not None and region != inside:
                raise self.fail(
                    f"{where}.region", f"{spec.name} is inside {inside}: its region is {inside!r}"
                )
        elif region in receptacles:
            inside = region
        if inside is not None:
            if under is not None:
                raise self.fail(
                    f"{where}.under", "an object cannot be both under a cover and in a receptacle"
                )
            if spec.cover or spec.receptacle_capacity is not None:
                what = "a cover" if spec.cover else "a receptacle"
                raise self.fail(
                    f"{where}.inside", f"{spec.name} is {what}: it cannot be inside another object"
                )
        return region, under, inside

    def locate(
        self,
        where: str,
        t: Mapping[str, Any],
        spec: ObjectSpec,
        region: str | None,
        under: str | None,
        inside: str | None,
        state: TrueState,
        receptacles: set[str],
    ) -> Placement:
        anchor_name = under if under is not None else inside
        if anchor_name is None:
            if region is None:
                raise self.fail(
                    f"{where}.region", "missing (give region, x, y; or under; or inside)"
                )
            if region not in self.layout.regions:
                known = {*self.layout.regions, *receptacles}
                raise self.fail(
                    f"{where}.region", f"unknown region {region!r}; regions: {_names(known)}"
                )
            for key in ("x", "y"):
                if key not in t:
                    raise self.fail(f"{where}.{key}", "missing (required with region)")
            x, y = self.number(t["x"], f"{where}.x"), self.number(t["y"], f"{where}.y")
            r = self.layout.regions[region]
            if not r.contains(x, y, margin=spec.radius - 1e-9):
                raise self.fail(
                    where,
                    f"{spec.name} at ({x:.3f}, {y:.3f}) is outside {region}: with its radius "
                    f"{spec.radius} m it must lie within {r.rect}",
                )
            return Placement(region, x, y)
        if anchor_name not in state.placements:
            raise self.fail(
                where,
                f"{spec.name} is {'under' if under is not None else 'inside'} {anchor_name}, "
                f"whose location is unknown: give {spec.name} a location or unknown = true",
            )
        anchor = state.placements[anchor_name]
        if under is not None:
            if region is not None and region != anchor.region:
                raise self.fail(
                    f"{where}.region",
                    f"{spec.name} is under {under}, which is on {anchor.region}, not {region}",
                )
            region = anchor.region
        else:
            region = anchor_name
        x = self.number(t.get("x", anchor.x), f"{where}.x")
        y = self.number(t.get("y", anchor.y), f"{where}.y")
        limit = state.radius(anchor_name) - spec.radius
        if limit < 0 or math.hypot(x - anchor.x, y - anchor.y) > limit + 1e-9:
            relation = "under" if under is not None else "inside"
            raise self.fail(
                where,
                f"{spec.name} at ({x:.3f}, {y:.3f}) does not fit {relation} {anchor_name} at "
                f"({anchor.x:.3f}, {anchor.y:.3f})",
            )
        return Placement(region, x, y)

    def check_room(
        self,
        where: str,
        spec: ObjectSpec,
        place: Placement,
        under: str | None,
        inside: str | None,
        state: TrueState,
    ) -> None:
        """Capacity and overlaps of a new object at ``place``."""
        region = place.region
        if state.occupied(region):
            raise self.fail(
                f"{where}.inside" if inside is not None else f"{where}.region",
                f"{region} is full: it holds {', '.join(state.objects_in(region))} "
                f"(capacity {state.capacity(region)})",
            )
        if under is None:
            hits = state.overlapping(region, place.x, place.y, spec.radius)
        else:  # under a cover: only the other objects under the same cover can be in the way
            hits = tuple(
                o
                for o in state.covers(under)
                if math.hypot(state.placements[o].x - place.x, state.placements[o].y - place.y)
                < spec.radius + state.radius(o) - 1e-9
            )
        if hits:
            raise self.fail(
                where,
                f"{spec.name} at ({place.x:.3f}, {place.y:.3f}) overlaps {', '.join(hits)} "
                f"on {region}",
            )

    # -------------------------------------------------------------------------- containers

    def open_table(self, value: Any, where: str) -> dict[str, bool]:
        openable = sorted(n for n, r in self.layout.regions.items() if r.openable)
        out = dict.fromkeys(openable, False)
        if not isinstance(value, Mapping):
            raise self.fail(where, f"must be a table, got {_fmt(value)}")
        for key, v in value.items():
            if key not in self.layout.regions:
                raise self.fail(
                    f"{where}.{key}", f"unknown container {key!r}; containers: {_names(openable)}"
                )
            if key not in out:
                raise self.fail(
                    f"{where}.{key}", f"{key} cannot be opened; containers: {_names(openable)}"
                )
            out[key] = self.boolean(v, f"{where}.{key}")
        return out

    def robot(self, value: Any) -> BaseConf:
        t = self.table(value, "robot", ("x", "y", "theta"))
        hx, hy, ht = self.layout.home
        x = self.number(t.get("x", hx), "robot.x")
        y = self.number(t.get("y", hy), "robot.y")
        theta = self.number(t.get("theta", ht), "robot.theta")
        hit = base_collision(self.layout, x, y)
        if hit is not None:
            raise self.fail("robot", f"the base at ({x:.2f}, {y:.2f}) collides with {hit}")
        return BaseConf(x, y, theta)

    # ------------------------------------------------------------------------------- belief

    def belief(
        self,
        value: Any,
        entries: list[tuple[str, Mapping[str, Any]]],
        specs: Mapping[str, ObjectSpec],
        open_: Mapping[str, bool],
    ) -> InitialBelief:
        t = self.table(value, "belief", ("objects", "open", "searched", "jammed"))
        covers = tuple(n for n, s in specs.items() if s.cover)
        searched = self.places(t.get("searched", []), "belief.searched", covers)
        jammed = self.containers(t.get("jammed", []), "belief.jammed")
        overrides: dict[str, tuple[str, Mapping[str, Any]]] = {}
        truth_names = [str(e["name"]) for _, e in entries]
        for i, raw in enumerate(self.array(t.get("objects", []), "belief.objects")):
            where = f"belief.objects[{i}]"
            b = self.table(raw, where, (*_OBJECT_FIELDS, "unknown", "absent"))
            if "name" not in b:
                raise self.fail(f"{where}.name", "missing (required)")
            name = self.catalogue_object(b["name"], f"{where}.name")
            if name not in truth_names:
                raise self.fail(
                    f"{where}.name",
                    f"{name!r} is not among the scenario's objects: {_names(truth_names)}",
                )
            if name in overrides:
                raise self.fail(f"{where}.name", f"object {name!r} is listed twice")
            told = self.properties(b.get("properties", []), f"{where}.properties")
            hidden = sorted(HIDDEN & told)
            if hidden:
                raise self.fail(
                    f"{where}.properties",
                    f"{', '.join(hidden)}: a state the domain does not model is never believed",
                )
            overrides[name] = (where, b)
        merged: list[tuple[str, Mapping[str, Any]]] = []
        for where, e in entries:
            name = str(e["name"])
            if name not in overrides:
                merged.append((where, e))
                continue
            b_where, b = overrides[name]
            if self.boolean(b.get("absent", False), f"{b_where}.absent"):
                if len(b) > 2:
                    raise self.fail(f"{b_where}.absent", "an absent object takes no other field")
                continue
            moved = b.get("unknown") or any(k in b for k in _LOCATION_FIELDS)
            keep = {k: v for k, v in e.items() if k not in _LOCATION_FIELDS or not moved}
            merged.append((b_where, {**keep, **{k: v for k, v in b.items() if k != "absent"}}))
        state = TrueState(self.layout, specs, BaseConf(*self.layout.home))
        objects = self.place_objects(merged, state, belief=True)
        believed_open = dict(open_)
        overridden = self.open_table(t.get("open", {}), "belief.open")
        believed_open.update({k: overridden[k] for k in t.get("open", {})})
        return InitialBelief(tuple(objects), believed_open, searched, jammed)

    # -------------------------------------------------------------------------------- noise

    def noise(self, value: Any, names: tuple[str, ...]) -> Noise:
        fields = ("pose_sigma", "base_sigma", "miss_prob", "slip_prob", "displace", "confuse")
        t = self.table(value, "noise", fields)
        confuse = tuple(
            self.confusion(c, f"noise.confuse[{i}]", names)
            for i, c in enumerate(self.array(t.get("confuse", []), "noise.confuse"))
        )
        displace = tuple(
            self.disturbance(d, f"noise.displace[{i}]", names)
            for i, d in enumerate(self.array(t.get("displace", []), "noise.displace"))
        )
        return Noise(
            pose_sigma=self.sigma(t.get("pose_sigma", 0.0), "noise.pose_sigma"),
            base_sigma=self.sigma(t.get("base_sigma", 0.0), "noise.base_sigma"),
            miss_prob=self.probability(t.get("miss_prob", 0.0), "noise.miss_prob"),
            slip_prob=self.probability(t.get("slip_prob", 0.0), "noise.slip_prob"),
            displace=displace,
            confuse=confuse,
        )

    def confusion(self, value: Any, where: str, names: tuple[str, ...]) -> Confusion:
        t = self.table(value, where, ("object", "as", "prob"))
        for key in ("object", "as"):
            if key not in t:
                raise self.fail(f"{where}.{key}", "missing (required)")
        obj = self.scenario_object(t["object"], f"{where}.object", names)
        seen_as = self.catalogue_object(t["as"], f"{where}.as")
        if seen_as == obj:
            raise self.fail(f"{where}.as", f"{obj} cannot be taken for itself")
        prob = self.probability(t.get("prob", 1.0), f"{where}.prob")
        return Confusion(obj, seen_as, prob)

    def disturbance(self, value: Any, where: str, names: tuple[str, ...]) -> Disturbance:
        if not isinstance(value, Mapping):
            raise self.fail(where, f"must be a table, got {_fmt(value)}")
        kind = self.string(value.get("kind"), f"{where}.kind")
        if kind == "slip":
            t = self.table(value, where, ("kind", "attempt"))
            return Disturbance(
                "slip", attempt=self.integer(t.get("attempt", 1), f"{where}.attempt", 1)
            )
        if kind == "nudge":
            t = self.table(value, where, ("kind", "object", "dx", "dy", "after"))
            for key in ("object", "after"):
                if key not in t:
                    raise self.fail(f"{where}.{key}", "missing (required)")
            obj = self.scenario_object(t["object"], f"{where}.object", names)
            if self.catalogue[obj].cover:
                raise self.fail(f"{where}.object", f"{obj} is a cover: it cannot be nudged")
            dx = self.number(t.get("dx", 0.0), f"{where}.dx")
            dy = self.number(t.get("dy", 0.0), f"{where}.dy")
            if math.hypot(dx, dy) > MAX_NUDGE:
                raise self.fail(
                    where, f"a nudge moves at most {MAX_NUDGE} m (use an event to move objects)"
                )
            after = self.trigger(t["after"], f"{where}.after")
            return Disturbance("nudge", object=obj, dx=dx, dy=dy, after=after)
        raise self.fail(
            f"{where}.kind", f"unknown disturbance {kind!r}; kinds: {', '.join(DISTURBANCE_KINDS)}"
        )

    def scenario_object(self, value: Any, where: str, names: tuple[str, ...]) -> str:
        name = self.catalogue_object(value, where)
        if name not in names:
            raise self.fail(where, f"{name!r} is not among the scenario's objects: {_names(names)}")
        return name

    def trigger(self, value: Any, where: str) -> Trigger:
        t = self.table(value, where, ("skill", "count"))
        for key in ("skill", "count"):
            if key not in t:
                raise self.fail(f"{where}.{key}", "missing (required)")
        skill = self.string(t["skill"], f"{where}.skill")
        if skill not in SKILLS:
            raise self.fail(
                f"{where}.skill", f"unknown skill {skill!r}; skills: {', '.join(SKILLS)}"
            )
        return Trigger(skill, self.integer(t["count"], f"{where}.count", 1))

    # ------------------------------------------------------------------------------- events

    def events(self, value: Any, names: tuple[str, ...], truth: TrueState) -> tuple[Event, ...]:
        out = []
        present = list(names)
        receptacles = {n for n in truth.specs if truth.specs[n].receptacle_capacity is not None}
        covers = sorted(n for n in names if self.catalogue[n].cover)
        for i, raw in enumerate(self.array(value, "events")):
            where = f"events[{i}]"
            if not isinstance(raw, Mapping):
                raise self.fail(where, f"must be a table, got {_fmt(raw)}")
            if "type" not in raw:
                raise self.fail(f"{where}.type", "missing (required)")
            kind = self.string(raw["type"], f"{where}.type")
            if kind not in EVENT_TYPES:
                raise self.fail(
                    f"{where}.type", f"unknown event type {kind!r}; types: {', '.join(EVENT_TYPES)}"
                )
            if kind in ("move", "occupy"):
                allowed: tuple[str, ...] = (
                    "type",
                    "after",
                    "object",
                    "region",
                    "into",
                    "x",
                    "y",
                    "under",
                )
            else:
                allowed = ("type", "after", "object", "property")
            t = self.table(raw, where, allowed)
            for key in ("after", "object"):
                if key not in t:
                    raise self.fail(f"{where}.{key}", "missing (required)")
            after = self.trigger(t["after"], f"{where}.after")
            if kind == "occupy":
                obj = self.catalogue_object(t["object"], f"{where}.object")
            else:
                obj = self.scenario_object(t["object"], f"{where}.object", tuple(present))
            if obj not in present:
                present.append(obj)
            if kind in ("set_property", "clear_property"):
                if "property" not in t:
                    raise self.fail(f"{where}.property", "missing (required)")
                prop = self.string(t["property"], f"{where}.property")
                if prop not in STATES:
                    raise self.fail(
                        f"{where}.property",
                        f"unknown property {prop!r}; properties: {_names(STATES)}",
                    )
                out.append(Event(after, kind, obj, property=prop))
                continue
            targets = [k for k in ("region", "into", "under") if k in t]
            if len(targets) != 1:
                raise self.fail(where, f"a {kind} event needs exactly one of region, into, under")
            key = targets[0]
            target = self.string(t[key], f"{where}.{key}")
            spec = self.catalogue[obj]
            if key == "under":
                if "x" in t or "y" in t:
                    raise self.fail(f"{where}.under", "an object moved under a cover takes no x, y")
                if target not in covers:
                    raise self.fail(
                        f"{where}.under", f"unknown cover {target!r}; covers: {_names(covers)}"
                    )
                if spec.cover:
                    raise self.fail(f"{where}.object", f"{obj} is a cover: it cannot be under one")
                if self.catalogue[target].radius < spec.radius:
                    raise self.fail(f"{where}.under", f"{obj} does not fit under {target}")
                out.append(Event(after, kind, obj, under=target))
                continue
            if target in receptacles and target in present:
                if "x" in t or "y" in t:
                    raise self.fail(
                        f"{where}.{key}", "an object put into a receptacle takes no x, y"
                    )
                if target == obj or spec.cover or spec.receptacle_capacity is not None:
                    raise self.fail(f"{where}.object", f"{obj} cannot go into {target}")
                if self.catalogue[target].radius < spec.radius:
                    raise self.fail(f"{where}.{key}", f"{obj} does not fit into {target}")
                out.append(Event(after, kind, obj, region=target))
                continue
            if target not in self.layout.regions:
                known = sorted({*self.layout.regions, *(r for r in receptacles if r in present)})
                raise self.fail(
                    f"{where}.{key}", f"unknown region {target!r}; regions: {', '.join(known)}"
                )
            x = self.number(t["x"], f"{where}.x") if "x" in t else None
            y = self.number(t["y"], f"{where}.y") if "y" in t else None
            if (x is None) != (y is None):
                raise self.fail(where, "give both x and y, or neither (the region's centre)")
            r = self.layout.regions[target]
            cx, cy = (x, y) if x is not None and y is not None else r.center()
            if not r.contains(cx, cy, margin=spec.radius - 1e-9):
                raise self.fail(
                    where,
                    f"{obj} at ({cx:.3f}, {cy:.3f}) is outside {target}: with its radius "
                    f"{spec.radius} m it must lie within {r.rect}",
                )
            out.append(Event(after, kind, obj, region=target, x=x, y=y))
        return tuple(out)

    # --------------------------------------------------------------------------------- goal

    def goal(self, value: Any, names: tuple[str, ...]) -> str:
        t = self.table(value, "task", ("goal",))
        if "goal" not in t:
            raise self.fail("task.goal", "missing (required)")
        goal = t["goal"]
        if not isinstance(goal, str):
            raise self.fail("task.goal", f"must be PDDL text (a string), got {_fmt(goal)}")
        try:
            exprs = parse_all(goal, "task.goal")
        except PddlSyntaxError as e:
            raise self.fail("task.goal", f"malformed PDDL: {e.message}") from None
        if len(exprs) != 1 or not isinstance(exprs[0], SList):
            raise self.fail("task.goal", "must be one parenthesised PDDL formula")
        known = {*names, *self.layout.regions, *self.layout.furniture}
        self.check_atoms(exprs[0], known)
        return goal.strip()

    def check_atoms(self, e: SList, known: set[str]) -> None:
        head = e.head()
        if head is not None and head in GOAL_PREDICATES:
            args = e.items[1:]
            if len(args) != GOAL_PREDICATES[head]:
                raise self.fail(
                    "task.goal", f"({head} ...) takes {GOAL_PREDICATES[head]} argument(s)"
                )
            for a in args:
                if not isinstance(a, Sym):
                    raise self.fail("task.goal", f"({head} ...) takes names, not formulas")
                if not a.text.startswith("?") and a.text not in known:
                    raise self.fail(
                        "task.goal",
                        f"unknown name {a.text!r} in ({head} ...); "
                        f"names: {', '.join(sorted(known))}",
                    )
            return
        for item in e.items:
            if isinstance(item, SList):
                self.check_atoms(item, known)


_LOCATION_FIELDS = ("region", "x", "y", "under", "inside")
_OBJECT_FIELDS = ("name", *_LOCATION_FIELDS, "properties")
