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

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from llmpas.errors import InputError
from llmpas.inputs import read_toml
from llmpas.worlds.household.household_values import BaseConf, Placement
from llmpas.worlds.household.layout import Layout, ObjectSpec, default_objects, kitchen
from llmpas.worlds.household.state import TrueState

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
        from llmpas.worlds.household.scenario_parser import ScenarioParser  # it reads these values

        parser = ScenarioParser(
            source, layout or kitchen(floor=floor), catalogue or default_objects()
        )
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
        raise ScenarioError(
            f"unknown scenario {name!r}; scenarios: {name_list(builtin_scenarios())}"
        )
    return load_scenario(path, layout=layout)


def name_list(names: Any) -> str:
    """A sorted, comma-separated list of names (or "none")."""
    return ", ".join(sorted(names)) or "none"
