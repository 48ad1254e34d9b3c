"""The robot's side of the household: static knowledge, believed state, and planning problems.

Everything here is built from what the robot knows or perceives (a :class:`Belief`), never from
the simulator's true state.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from llmpas.execution.context import Belief
from llmpas.language.logic import Atom, Formula, atoms_of
from llmpas.language.problem import Problem, parse_formula
from llmpas.worlds.household.household_streams import DEFAULT_DEFERRED, make_streams
from llmpas.worlds.household.household_values import BaseConf, Placement
from llmpas.worlds.household.layout import Layout, ObjectSpec
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.kitchen.belief import pose_of, rests_at
from llmpas.worlds.kitchen.kitchen_problem import kitchen_problem, start_belief

PROCESS_PREDICATE = {"clean": "Sink", "cook": "Stove", "heat": "Microwave", "cool": "Fridge"}
PROPERTY_PREDICATE = {
    "dirty": "Dirty",
    "cleaned": "Cleaned",
    "cooked": "Cooked",
    "heated": "Heated",
    "cooled": "Cooled",
    "hot": "Hot",
    "wet": "Wet",
    "broken": "Broken",
    "spilled": "Spilled",
}


def is_drawer(region: str) -> bool:
    return region.startswith("drawer")


@dataclass(frozen=True)
class Household:
    """What the robot knows that does not change: the layout and the objects' shapes."""

    layout: Layout
    objects: Mapping[str, ObjectSpec]

    def search_places(self, containers: bool = False) -> tuple[str, ...]:
        """Where the robot can look for an object: table parts (and the floor), drawers,
        covers; with ``containers``, the other closed containers (fridge, microwave) too, which
        ``scan_container`` opens and looks into. (Without them by default: the list is quoted
        in recorded prompts.)"""
        regions = [
            r.name
            for r in self.layout.regions.values()
            if r.kind == "surface"
            or is_drawer(r.name)
            or (containers and r.kind == "container" and r.openable)
        ]
        return (*regions, *sorted(o for o, s in self.objects.items() if s.cover))

    def static_facts(self) -> set[Atom]:
        facts: set[Atom] = set()
        regions = dict(self.layout.regions)
        for r in regions.values():
            facts.add(Atom.of("Region", r.name))
            if r.kind == "surface":
                facts.add(Atom.of("Surface", r.name))
            if is_drawer(r.name):
                facts.add(Atom.of("Drawer", r.name))
            if r.openable:
                facts.add(Atom.of("Openable", r.name))
            if r.process:
                facts.add(Atom.of(PROCESS_PREDICATE[r.process], r.name))
            if r.capacity == 1:
                facts.add(Atom.of("Single", r.name))
        receptacles = [o for o in self.objects.values() if o.receptacle_capacity]
        for o in receptacles:
            facts.add(Atom.of("Region", o.name))
            if o.receptacle_capacity == 1:
                facts.add(Atom.of("Single", o.name))
        for o in self.objects.values():
            facts.add(Atom.of("Object", o.name))
            if o.cover:
                facts.add(Atom.of("Cover", o.name))
            for r in regions.values():
                if not o.cover or r.kind == "surface":
                    facts.add(Atom.of("Stackable", o.name, r.name))
            if not o.cover and not o.receptacle_capacity:
                facts |= {Atom.of("Stackable", o.name, b.name) for b in receptacles}
        return facts


def believe_at(belief: Belief, obj: str, place: Placement | None) -> None:
    """Believe ``obj`` rests at ``place`` (None: its whereabouts are unknown)."""
    rests_at(belief, obj, place)


def believed_place(belief: Belief, obj: str) -> Placement | None:
    return pose_of(belief, obj, Placement)


def initial_belief(
    house: Household,
    places: Mapping[str, Placement | None],
    base: BaseConf,
    open_regions: Iterable[str] = (),
    properties: Mapping[str, Collection[str]] | None = None,
    searched: Iterable[str] = (),
    jammed: Iterable[str] = (),
) -> Belief:
    """The robot's belief at the start: where it thinks objects are, what is open, its base,
    the places it has already searched (``(scanned P)``) and the doors it knows are jammed."""
    belief = start_belief(house.static_facts(), places, base)
    belief.facts |= {Atom("open", (r,)) for r in open_regions}
    for obj, props in (properties or {}).items():
        belief.facts |= {Atom(PROPERTY_PREDICATE[p].lower(), (obj,)) for p in props}
    belief.facts |= {Atom("scanned", (p,)) for p in searched}
    belief.facts |= {Atom("jammed", (r,)) for r in jammed}
    return belief


def capacity_facts(house: Household, belief: Belief) -> set[Atom]:
    """``(double R)`` for a region that holds two objects and is believed to hold one already.

    A region believed empty is planned without its limit: a plan puts at most one object into
    one place in the tasks here, and leaving the fact out keeps the search (and so the plans) of
    problems where no such region is in use exactly as they were. A place believed half full is
    planned with its limit: after one more object it is full."""
    out: set[Atom] = set()
    at = {a.args for a in belief.facts if a.predicate == "atpose"}
    for r in house.layout.regions.values():
        if r.capacity != 2:
            continue
        count = sum(
            1
            for a in belief.facts
            if a.predicate == "supported" and a.args[2] == r.name and a.args[:2] in at
        )
        if count >= 1:
            out.add(Atom.of("Double", r.name))
    return out


def believed_placements(
    house: Household, belief: Belief
) -> Iterator[tuple[str, str, Placement, ObjectSpec]]:
    """Every object believed at a placement: its name, its pose's name, the placement, its
    shape."""
    for a in sorted(belief.facts):
        if a.predicate != "atpose":
            continue
        obj, p = a.args
        place = belief.values.get(p)
        spec = house.objects.get(obj)
        if isinstance(place, Placement) and spec is not None:
            yield obj, p, place, spec


def blocking_facts(house: Household, belief: Belief) -> set[Atom]:
    """``(blocks P R)`` for every believed pose P on the floor in front of door R."""
    out: set[Atom] = set()
    fronts = [r.name for r in house.layout.regions.values() if r.front is not None]
    for _obj, p, place, spec in believed_placements(house, belief):
        if not house.layout.on_floor(place.region):
            continue  # only what stands on the floor blocks a door
        for r in fronts:
            if house.layout.blocked_by(r, place.x, place.y, spec.radius):
                out.add(Atom("blocks", (p, r)))
    return out


def make_problem(
    house: Household,
    belief: Belief,
    goal: Formula | str,
    rng: np.random.Generator,
    deferred: Collection[str] = DEFAULT_DEFERRED,
) -> Problem:
    """The planning problem from the believed state."""
    domain = load_domain()
    facts = set(belief.facts) | capacity_facts(house, belief) | blocking_facts(house, belief)
    facts |= search_facts(house, goal if not isinstance(goal, str) else parse_formula(goal, domain))
    streams = make_streams(
        house.layout, house.objects, lambda o: believed_place(belief, o), rng, deferred
    )
    return kitchen_problem(facts, belief, goal, streams, "household", domain)


def search_facts(house: Household, goal: Formula) -> set[Atom]:
    """``(searched C)`` for the closed containers (fridge, microwave) the goal asks to scan.

    ``Scanned`` is in no precondition, so ``scan_container`` is relevant only to such a goal;
    leaving it out of other problems keeps their search exactly as it was before the action
    existed."""
    containers = {
        r.name for r in house.layout.regions.values() if r.openable and not is_drawer(r.name)
    }
    return {
        Atom("searched", a.args)
        for a in atoms_of(goal)
        if a.predicate == "scanned" and a.args[0] in containers
    }
