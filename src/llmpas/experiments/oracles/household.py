"""The household's labelled oracle (an upper bound, never a default): answers with goals
computed from the simulator's TRUE state."""

from __future__ import annotations

from llmpas.experiments.oracles import answer, failed_literal, first_look
from llmpas.language.logic import Atom, Formula, Not
from llmpas.reasoning.llm import Request, Response
from llmpas.worlds.household.plugin import HouseholdSession
from llmpas.worlds.household.sim import HouseholdWorld


class Oracle:
    """Goals from the true state of ``world`` for the anomaly in each request."""

    name = "oracle"

    def __init__(self, world: HouseholdWorld) -> None:
        self.world = world

    def complete(self, request: Request) -> Response:
        c = failed_literal(request)
        return first_look() if c is None else answer(self.goals(c))

    def goals(self, c: Formula) -> list[Atom | Not]:
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


def oracle(session: HouseholdSession) -> Oracle:
    return Oracle(session.sim)


__all__ = ["Oracle", "oracle"]
