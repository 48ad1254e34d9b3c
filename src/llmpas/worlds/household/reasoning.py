"""What the reasoner is told about the household, and the oracle that knows its true state.

Everything in a prompt comes from the robot's belief and the domain; only :class:`Oracle` reads the
simulator's truth, and it is used only as an upper bound (never as a default).
"""

from __future__ import annotations

from collections.abc import Callable
from types import MappingProxyType

from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Belief
from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goals import Vocabulary
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.methods import Situation
from llmpas.reasoning.program import Call
from llmpas.worlds.household.problem import Household, believed_place
from llmpas.worlds.household.sim import HouseholdWorld

ACTIONS = {
    "pick": ("pick up an object from where it rests (the hand must be empty)", ("holding",)),
    "place": (
        "put the held object on a table region, into a drawer, an appliance or a bowl",
        ("on",),
    ),
    "scan_table": ("look at a table region and find what is on it", ("scanned",)),
    "scan_drawer": ("look into an open drawer", ("scanned",)),
    "scan_cover": ("lift a cover such as the upside-down basket and look under it", ("scanned",)),
    "open": ("open a drawer, the microwave or the fridge", ("open",)),
    "close": ("close a drawer, the microwave or the fridge", ()),
    "clean": ("clean an object that is in the sink", ("cleaned",)),
    "cook": ("cook a clean object that is on the stove", ("cooked",)),
    "heat": ("heat an object in the closed microwave", ("heated",)),
    "cool": ("cool a clean object in the closed fridge", ("cooled",)),
}
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
}


PROGRAM_CALLS = MappingProxyType(
    {
        "pick": Call(("obj",), "holding", (0,)),
        "place": Call(("obj", "region"), "on", (0, 1)),
        "scan_table": Call(("region",), "scanned", (0,)),
        "scan_drawer": Call(("drawer",), "scanned", (0,)),
        "scan_cover": Call(("cover",), "scanned", (0,)),
        "open": Call(("container",), "open", (0,)),
        "close": Call(("container",), "open", (0,), negated=True),
        "clean": Call(("obj",), "cleaned", (0,)),
        "cook": Call(("obj",), "cooked", (0,)),
        "heat": Call(("obj",), "heated", (0,)),
        "cool": Call(("obj",), "cooled", (0,)),
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
        }
    )


def action_library() -> str:
    lines = []
    for name, (text, makes) in ACTIONS.items():
        made = f" — makes true: {', '.join(makes)}" if makes else ""
        lines.append(f"- {name}: {text}{made}")
    return "\n".join(lines)


def predicate_list() -> str:
    return "\n".join(f"- ({n} {args}): {text}" for n, (args, text) in PREDICATES.items())


def environment(house: Household, belief: Belief) -> str:
    """The believed state, as short sentences."""
    lines = []
    for obj in sorted(house.objects):
        place = believed_place(belief, obj)
        held = bool(belief.matching("atgrasp", obj))
        props = sorted(
            a.predicate
            for a in belief.facts
            if a.args == (obj,)
            and a.predicate in ("dirty", "cleaned", "cooked", "heated", "cooled")
        )
        where = (
            "held by the robot" if held else f"on {place.region}" if place else "location unknown"
        )
        if place is None and not held and not _mentioned(belief, obj):
            continue
        lines.append(f"- {obj}: {where}" + (f" ({', '.join(props)})" if props else ""))
    opened = sorted(a.args[0] for a in belief.facts if a.predicate == "open")
    closed = sorted(
        r.name for r in house.layout.regions.values() if r.openable and r.name not in opened
    )
    lines.append(f"- open: {', '.join(opened) or 'nothing'}; closed: {', '.join(closed)}")
    regions = ", ".join(sorted(house.layout.regions))
    lines.append(
        f"- regions: {regions}; covers: "
        + ", ".join(o for o, s in house.objects.items() if s.cover)
    )
    return "\n".join(lines)


def _mentioned(belief: Belief, obj: str) -> bool:
    return any(obj in a.args for a in belief.facts if a.predicate != "object")


def situation(
    house: Household, belief: Belief, report: AnomalyReport, task: str, history: str = ""
) -> Situation:
    return Situation(
        anomaly=report.describe(),
        actions=action_library(),
        predicates=predicate_list(),
        environment=environment(house, belief),
        task=f"the robot must achieve {task}",
        history=history,
        calls=PROGRAM_CALLS,
        objects=tuple(sorted(house.objects)),
    )


# --------------------------------------------------------------------------------- oracle


class Oracle:
    """**Oracle** (an upper bound, never a default): answers with goals computed from the
    simulator's TRUE state. Implements the LLM protocol so the same loop runs with it."""

    name = "oracle"

    def __init__(self, world: HouseholdWorld, report: Callable[[], AnomalyReport | None]) -> None:
        self.world = world
        self.report = report

    def complete(self, request: Request) -> Response:
        r = self.report()
        if request.tag == "first-look" or r is None:
            return Response("Look where the truth says.", model="oracle")
        return Response(f"(and {' '.join(map(str, self.goals(r)))})", model="oracle")

    def goals(self, r: AnomalyReport) -> list[Atom | Not]:
        c = r.constraint
        atom = c.arg if isinstance(c, Not) else c
        if not isinstance(atom, Atom):
            return []
        if atom.predicate == "on" and not isinstance(c, Not):
            return [self._find(atom.args[0])]
        if atom.predicate == "full":
            return [self._clear(atom.args[0])]
        if atom.predicate == "dirty":
            return [Atom("cleaned", (atom.args[0],))]
        return []

    def _find(self, obj: str) -> Atom:
        truth = self.world.truth
        cover = truth.covered.get(obj)
        if cover is not None:
            return Atom("scanned", (cover,))
        if obj not in truth.placements:  # held: nothing to look for
            return Atom("holding", (obj,))
        return Atom("scanned", (truth.placements[obj].region,))

    def _clear(self, region: str) -> Atom:
        truth = self.world.truth
        blocker = sorted(truth.objects_in(region))[0]
        free = next(
            r
            for r in sorted(self.world.layout.regions)
            if self.world.layout.regions[r].kind == "surface" and not truth.objects_in(r)
        )
        return Atom("on", (blocker, free))
