"""The loop's search memory (:class:`SearchMemory`): over a world's
:class:`~llmpas.worlds.api.SearchModel` and the robot's belief, what has been searched for each
lost object and what is left. The prompt (:meth:`SearchMemory.history`), the decoding grammar
(:meth:`SearchMemory.exhausted`) and the validator (:meth:`SearchMemory.searching`) all read it.

It knows nothing of a world but its search model: it is built from the model, the domain's
semantics and callables that read the belief, so a test can run it on a few facts.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Set
from dataclasses import dataclass, field
from typing import Any

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.language.logic import Atom, Formula, atoms_of
from llmpas.language.semantics import Semantics
from llmpas.reasoning.goal_reading import Literal
from llmpas.system.anomaly_memory import Anomaly
from llmpas.worlds.api import SearchModel


@dataclass
class SearchMemory:
    """What was searched for each object, in one run.

    ``model``: the world's search words and its "lost" test; ``sem``: the domain's semantics
    (``location`` may be derived); ``facts``: the belief's facts now; ``objects``: the objects
    ``(location O P)`` may name; ``task``: the task goal (its objects are the ones searched
    for); ``list_unsearched``: the prompt and feedback list the places not searched yet."""

    model: SearchModel
    sem: Semantics
    facts: Callable[[], Set[Atom]]
    objects: Callable[[], Iterable[str]]
    task: Formula
    list_unsearched: bool = True
    searched: dict[str, set[str]] = field(default_factory=dict)  # object -> places, in vain
    seen: dict[tuple[str, str], frozenset[Atom]] = field(default_factory=dict)  # at the search

    def look(self, place: str) -> Atom:
        """The goal that searches ``place``."""
        return Atom(self.model.predicate, (place,))

    def is_look(self, g: Literal | Formula) -> bool:
        return isinstance(g, Atom) and g.predicate == self.model.predicate

    def remember(self, report: AnomalyReport) -> None:
        """A failed detection: the places it looked at are searched for its object."""
        obj = Anomaly(report).detected(self.model.detection)
        if obj is not None:
            for place in self.model.looked_at(report):
                self.searched_for(obj, place)

    def searched_in(self, goal: Formula) -> None:
        """A search goal reached while an object is still lost: that place is searched."""
        lost = [o for o in self.searched if self.model.lost(o)]
        for g in atoms_of(goal):
            if g.predicate == self.model.predicate:
                for obj in lost:
                    self.searched_for(obj, g.args[0])

    def searched_for(self, obj: str, place: str) -> None:
        self.searched.setdefault(obj, set()).add(place)
        self.seen[obj, place] = self.about(place)

    def about(self, place: str, state: Any = None) -> frozenset[Atom]:
        """What the robot believes about ``place``: the facts that name it, and where objects
        are believed to rest there (``(location OBJ place)``, derived; ``state``: the belief's,
        when the caller has it)."""
        facts = self.facts()
        named = {a for a in facts if place in a.args}
        state = self.sem.state(facts) if state is None else state
        there = {Atom(self.model.location, (o, place)) for o in sorted(self.objects())}
        return frozenset(named | {a for a in there if self.sem.holds(a, state)})

    def refresh(self) -> None:
        """A place searched in vain stays searched while what the robot believes about it is
        unchanged; a cover lifted from it or an object put there makes it worth another look."""
        state = self.sem.state(self.facts())  # derived once for all places
        for obj, places in self.searched.items():
            for place in sorted(places):
                if self.seen.get((obj, place)) != self.about(place, state):
                    places.discard(place)
                    self.seen.pop((obj, place), None)

    def searching(self) -> dict[str, set[str]]:
        """The places searched for each object: those searched in vain this run (while what the
        robot believes about them is unchanged) and, for an object still lost, every place the
        belief says was searched (``(scanned P)``: by the scenario, an earlier round or an
        earlier run; such a goal would already hold). The prompt, the decoding grammar and the
        validator all read this."""
        self.refresh()
        out = {obj: set(places) for obj, places in self.searched.items()}
        scanned = {
            a.args[0] for a in self.facts() if a.predicate == self.model.predicate and a.args
        }
        if scanned:
            named = {o for a in atoms_of(self.task) for o in a.args}
            for obj in sorted(named | set(out)):
                if self.model.lost(obj):
                    out.setdefault(obj, set()).update(scanned)
        return out

    def left(self, regions: Set[str]) -> list[str]:
        """The places not searched yet, of those the robot can look at."""
        return [p for p in self.model.places() if p not in regions]

    def not_searched(self, regions: Set[str]) -> str:
        """`` (not searched yet: ...)`` for feedback, when the assist lists them."""
        rest = self.left(regions)
        listed = rest and self.list_unsearched
        return f" (not searched yet: {', '.join(rest)})" if listed else ""

    def exhausted(self) -> tuple[Literal, ...]:
        """Searches that cannot help (places already searched for a lost object), in both
        spellings: ``(scanned P)`` and ``(on X P)``; left out of the LLM's decoding."""
        out: list[Literal] = []
        for obj, regions in self.searching().items():
            if self.model.lost(obj):
                for place in sorted(regions):
                    # (on X P) stays out even when it is the task's literal: X is lost, so no
                    # plan reaches it before X is found (it is not read as a search, though)
                    out += [self.look(place), Atom(self.model.location, (obj, place))]
        return tuple(out)

    def history(self) -> list[str]:
        """The prompt's lines on the searches: where each object was not found, and (with the
        assist) where it was not searched yet, while it is still lost (once a look saw it,
        the belief says where it is)."""
        lines = []
        for obj, regions in self.searching().items():
            if not regions:
                continue
            lines.append(f"- {obj} was not found on {', '.join(sorted(regions))}")
            if self.list_unsearched and self.model.lost(obj):
                lines.append(
                    f"- places not searched yet for {obj}: {', '.join(self.left(regions))}"
                )
        return lines

    def as_search(self, g: Literal) -> Literal:
        """``(scanned P)`` for ``(on X P)`` with X lost and P a place to search; else ``g``."""
        m = self.model
        if not (isinstance(g, Atom) and g.predicate == m.location and len(g.args) == 2):
            return g
        if m.lost(g.args[0]) and g.args[1] in m.places():
            return self.look(g.args[1])
        return g


__all__ = ["SearchMemory"]
