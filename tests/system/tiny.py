"""A tiny in-memory search world for the loop's collaborators: a domain of four predicates, a
belief that is a set of facts, and a search model over three tables (no simulator, no planner)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.language.domain import parse_domain
from llmpas.language.logic import And, Atom, Formula
from llmpas.language.semantics import Semantics
from llmpas.system.search_memory import SearchMemory

DOMAIN = parse_domain(
    """(define (domain tiny)
         (:requirements :strips :negative-preconditions)
         (:predicates (on ?o ?p) (scanned ?p) (holding ?o) (clean ?o)))""",
    "tiny.pddl",
)
SEM = Semantics(DOMAIN, {}, {}, strict_costs=False)
PLACES = ("t1", "t2", "t3")
OBJECTS = ("cup", "plate")


@dataclass
class Facts:
    """The robot's belief: a set of facts a test changes."""

    facts: set[Atom] = field(default_factory=set)

    def __call__(self) -> frozenset[Atom]:
        return frozenset(self.facts)


@dataclass
class Model:
    """A :class:`~llmpas.worlds.api.SearchModel`: an object is lost when the belief neither
    places it nor holds it."""

    belief: Facts
    predicate: str = "scanned"
    location: str = "on"
    detection: str = "Detected"

    def places(self) -> tuple[str, ...]:
        return PLACES

    def looked_at(self, report: AnomalyReport) -> tuple[str, ...]:
        return tuple(report.explored.get("view", ()))

    def lost(self, obj: str) -> bool:
        known = {a.args[0] for a in self.belief.facts if a.predicate in ("on", "holding")}
        return obj in OBJECTS and obj not in known


def atom(text: str) -> Atom:
    name, *args = text.strip("()").split()
    return Atom(name, tuple(args))


def memory(facts: Facts, task: Formula | None = None, list_unsearched: bool = True) -> SearchMemory:
    return SearchMemory(
        Model(facts),
        SEM,
        facts,
        lambda: OBJECTS,
        task if task is not None else And((atom("(holding cup)"),)),
        list_unsearched,
    )


def failed_look(obj: str, viewed: tuple[str, ...], name: str = "Detected") -> AnomalyReport:
    """A failed detection of ``obj`` that looked at ``viewed``."""
    explored: Mapping[str, tuple[str, ...]] = {"view": viewed}
    return AnomalyReport(
        action="pick",
        args=(obj,),
        steps=(0,),
        subtree="pick",
        sub_action="look",
        constraint=Atom("on", (obj, "?")),
        constraint_name=name,
        reason=f"{obj} not seen",
        explored=explored,
        attempts=len(viewed),
        failures={name: len(viewed)},
        observations=(),
        belief=(),
    )
