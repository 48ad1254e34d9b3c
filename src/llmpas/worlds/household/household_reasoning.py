"""What the reasoner is told about the household: its prompt tables (as data), the goal
vocabulary and the believed environment. Everything here comes from the robot's belief and the
domain, never from the simulator's truth (the labelled oracle lives in
:mod:`llmpas.worlds.household.household_oracle`).
"""

from __future__ import annotations

from types import MappingProxyType

from llmpas.execution.context import Belief
from llmpas.reasoning.tables import Call, PromptTables, Vocabulary
from llmpas.worlds.household.household_problem import Household, believed_place
from llmpas.worlds.kitchen.kitchen_reasoning import CALLS, whereabouts

ACTIONS = {
    "pick": ("pick up an object from where it rests (the hand must be empty)", ("holding",)),
    "place": (
        "put the held object on a table region, into a drawer, an appliance or a bowl",
        ("on",),
    ),
    "scan_table": ("look at a table region and find what is on it", ("scanned",)),
    "scan_drawer": ("look into an open drawer", ("scanned",)),
    "scan_cover": ("lift a cover such as the upside-down basket and look under it", ("scanned",)),
    "scan_container": ("open the fridge or the microwave first, then look inside", ("scanned",)),
    "open": (
        "open a drawer, the microwave or the fridge (not when jammed or obstructed)",
        ("open",),
    ),
    "close": ("close a drawer, the microwave or the fridge", ()),
    "clean": (
        "clean an object that is in the sink (also cools a hot one and rinses a spilled one)",
        ("cleaned",),
    ),
    "cook": ("cook a clean object that is on the stove", ("cooked",)),
    "heat": ("heat an object in the closed microwave", ("heated",)),
    "cool": ("cool a clean object in the closed fridge", ("cooled",)),
    "dry": ("wipe a wet object dry on a table region", ()),
}
STATES = ("dirty", "cleaned", "cooked", "heated", "cooled", "hot", "wet", "broken", "spilled")
PREDICATES = {
    "on": ("?o ?r", "object ?o rests on or in region ?r (a table region, drawer, appliance, bowl)"),
    "holding": ("?o", "the robot holds object ?o"),
    "scanned": (
        "?r",
        "the robot has looked at region or cover ?r (a goal to search for an object whose "
        "location is unknown)",
    ),
    "open": ("?r", "drawer / microwave / fridge ?r is open"),
    "cleaned": ("?o", "object ?o has been cleaned"),
    "cooked": ("?o", "object ?o has been cooked"),
    "heated": ("?o", "object ?o has been heated"),
    "cooled": ("?o", "object ?o has been cooled"),
    "hot": ("?o", "object ?o is hot (it does not go into the fridge)"),
    "spilled": ("?o", "object ?o is spilled over (it is rinsed before heating)"),
    "wet": ("?o", "object ?o is wet (it is dried before it goes into a drawer)"),
    "obstructed": ("?r", "something stands in front of the door of ?r"),
}


PROGRAM_CALLS = MappingProxyType(
    {
        **CALLS,
        "scan_drawer": Call(("drawer",), "scanned", (0,)),
        "scan_cover": Call(("cover",), "scanned", (0,)),
        "scan_container": Call(("container",), "scanned", (0,)),
        "open": Call(("container",), "open", (0,)),
        "close": Call(("container",), "open", (0,), negated=True),
        "clean": Call(("obj",), "cleaned", (0,)),
        "cook": Call(("obj",), "cooked", (0,)),
        "heat": Call(("obj",), "heated", (0,)),
        "cool": Call(("obj",), "cooled", (0,)),
        "dry": Call(("obj",), "wet", (0,), negated=True),
    }
)


def vocabulary(house: Household) -> Vocabulary:
    """The goal predicates with the objects allowed at each argument."""
    objects = frozenset(o for o, s in house.objects.items() if not s.cover)
    covers = frozenset(o for o, s in house.objects.items() if s.cover)
    regions = frozenset(house.layout.regions)
    receptacles = frozenset(o for o, s in house.objects.items() if s.receptacle_capacity)
    openable = frozenset(r.name for r in house.layout.regions.values() if r.openable)
    everything = objects | covers
    return Vocabulary(
        {
            "on": (everything, regions | receptacles),
            "holding": (everything,),
            "scanned": (regions | covers,),
            "open": (openable,),
            "cleaned": (objects,),
            "cooked": (objects,),
            "heated": (objects,),
            "cooled": (objects,),
            "hot": (objects,),
            "spilled": (objects,),
            "wet": (objects,),
            "obstructed": (openable,),
        }
    )


def prompt_tables(house: Household) -> PromptTables:
    return PromptTables(ACTIONS, PREDICATES, PROGRAM_CALLS, tuple(sorted(house.objects)))


def environment(house: Household, belief: Belief) -> str:
    """The believed state, as short sentences."""
    lines = []
    for obj in sorted(house.objects):
        place = believed_place(belief, obj)
        held = bool(belief.matching("atgrasp", obj))
        props = sorted(
            a.predicate for a in belief.facts if a.args == (obj,) and a.predicate in STATES
        )
        where = whereabouts(belief, obj, place)
        if place is None and not held and not _mentioned(belief, obj):
            continue
        lines.append(f"- {obj}: {where}" + (f" ({', '.join(props)})" if props else ""))
    opened = sorted(a.args[0] for a in belief.facts if a.predicate == "open")
    closed = sorted(
        r.name for r in house.layout.regions.values() if r.openable and r.name not in opened
    )
    lines.append(f"- open: {', '.join(opened) or 'nothing'}; closed: {', '.join(closed)}")
    jammed = sorted(a.args[0] for a in belief.facts if a.predicate == "jammed")
    if jammed:
        lines.append(f"- jammed (do not open): {', '.join(jammed)}")
    regions = ", ".join(sorted(house.layout.regions))
    lines.append(
        f"- regions: {regions}; covers: "
        + ", ".join(o for o, s in house.objects.items() if s.cover)
    )
    return "\n".join(lines)


def _mentioned(belief: Belief, obj: str) -> bool:
    return any(obj in a.args for a in belief.facts if a.predicate != "object")
