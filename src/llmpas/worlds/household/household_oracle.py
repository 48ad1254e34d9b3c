"""The household's labelled oracle (an upper bound, never a default): answers with goals
computed from the simulator's TRUE state."""

from __future__ import annotations

from llmpas.language.logic import Atom, Not, atoms_of
from llmpas.language.problem import parse_formula
from llmpas.reasoning.truth_oracle import TruthOracle
from llmpas.worlds.household.household_plugin import HouseholdSession
from llmpas.worlds.household.sim import HouseholdWorld
from llmpas.worlds.household.state import (
    HIDDEN,
    PROCESS_EFFECTS,
    PROCESS_REMOVES,
)


class Oracle(TruthOracle):
    """Goals from the true state of ``world`` for the anomaly in each request."""

    def __init__(self, world: HouseholdWorld, task: tuple[Atom, ...] = ()) -> None:
        self.world = world
        self.task = task  # the task's atoms (what was to go where)

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        if atom.predicate in ("on", "atgrasp") and not negated:  # not where / not what it was
            return [self._find(atom.args[0])]
        if atom.predicate == "open" and not negated:  # a closed drawer, where it was believed open
            return [atom]
        if atom.predicate == "full":
            return self._clear(atom.args[0])
        if atom.predicate in ("dirty", "hot", "spilled"):
            return [Atom("cleaned", (atom.args[0],))]
        if atom.predicate in ("wet", "soaks"):
            return [Not(Atom("wet", (atom.args[0],)))]
        if atom.predicate == "obstructed":  # the task again: the replan moves what blocks
            return list(self.task)
        if atom.predicate == "jammed":
            return self._elsewhere(atom.args[0])
        if atom.predicate in PROCESS_EFFECTS and not atom.args and not negated:
            return self._process_failed()  # a process failed for a cause the domain lacks
        return []

    def _process_failed(self) -> list[Atom | Not]:
        """The last failed process: an object state the domain does not model goes away by the
        first process that removes it (rinsing before heating); another object in an appliance
        that processes one at a time goes to a free table part."""
        failed = [e for e in self.world.skill_calls("process") if not e.ok]
        if not failed:
            return []
        obj, appliance, _how = failed[-1].args
        if failed[-1].reason == "crowded":
            truth = self.world.truth
            others = sorted(o for o in truth.objects_in(appliance) if o != obj)
            free = self._free_surfaces()
            return [Atom("on", (o, free[i % len(free)])) for i, o in enumerate(others)]
        states = self.world.truth.properties.get(obj, set()) & HIDDEN
        if failed[-1].reason not in states:
            return []
        for process in sorted(PROCESS_REMOVES):
            if failed[-1].reason in PROCESS_REMOVES[process] and process in PROCESS_EFFECTS:
                return [Atom(PROCESS_EFFECTS[process], (obj,))]
        return []

    def _free_surfaces(self) -> list[str]:
        """The empty table parts (each occupant goes to its own: two on one part can exceed the
        planner's limits)."""
        truth, layout = self.world.truth, self.world.layout
        return [
            r
            for r in sorted(layout.regions)
            if layout.regions[r].kind == "surface"
            and layout.furniture[layout.regions[r].furniture].solid
            and not truth.objects_in(r)
        ]

    def _elsewhere(self, jammed: str) -> list[Atom | Not]:
        """What was to go into a jammed container goes into the first other one of its kind
        that truly opens and has room."""
        truth, layout = self.world.truth, self.world.layout
        kind = layout.regions[jammed].kind
        meant = [a.args[0] for a in self.task if a.predicate == "on" and a.args[1] == jammed]
        obj = meant[0] if meant else truth.held
        if obj is None:
            return []
        for name in sorted(layout.regions):
            region = layout.regions[name]
            if name == jammed or region.kind != kind or not region.openable:
                continue
            if obj in truth.objects_in(name):
                continue
            if name not in truth.jammed and len(truth.objects_in(name)) < 2:
                return [Atom("on", (obj, name))]
        return []

    def _find(self, obj: str) -> Atom:
        """Look where ``obj`` truly is: under its cover, or at the region it rests in; inside a
        receptacle (a bowl), where the receptacle is (a look at a region sees what is in the
        receptacles there); held (or in a held receptacle): nothing to look for."""
        truth = self.world.truth
        seen: set[str] = set()
        while obj not in seen:
            seen.add(obj)
            cover = truth.covered.get(obj)
            if cover is not None:
                return Atom("scanned", (cover,))
            if obj not in truth.placements:  # held: nothing to look for
                return Atom("holding", (obj,))
            region = truth.placements[obj].region
            if not truth.is_receptacle(region):
                return Atom("scanned", (region,))
            obj = region
        return Atom("scanned", (truth.placements[obj].region,))

    def _clear(self, region: str) -> list[Atom | Not]:
        """The first object truly in ``region`` to the first free table region (nothing when
        the region is truly empty by now: the occupant was taken out)."""
        truth = self.world.truth
        blockers = sorted(truth.objects_in(region))
        regions = self.world.layout.regions
        free = [
            r for r in sorted(regions) if regions[r].kind == "surface" and not truth.objects_in(r)
        ]
        if not blockers or not free:
            return []
        return [Atom("on", (blockers[0], free[0]))]


def oracle(session: HouseholdSession) -> Oracle:
    task = atoms_of(parse_formula(session.task, session.domain))
    made = Oracle(session.sim, tuple(task))
    made.vocabulary = session.vocabulary  # its answers are legal goals
    return made


__all__ = ["Oracle", "oracle"]
