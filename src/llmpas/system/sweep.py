"""A search sweeps: the places one object-loss consultation yields, searched in order until the
lost object is seen, within a counted budget (places searched and actions planned for them), so
that a sweep ends at the same place on any machine and under any load.

The order is the method's: a goal-writing method's looks in the order written; a choosing
method's chosen look, then the looks of the rest of its ranking, in rank order (for
``flp-choose``: every unsearched place the candidates hold, ranked by the model;
``candidates-first``: the enumeration's order; ``candidates-random``: its seeded shuffle). A
place searched in vain before is never searched again, a look no plan reaches is passed over,
and what every look saw stays in the belief (the loop never forgets it).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from llmpas.reasoning.goal_reading import Literal


@dataclass(frozen=True)
class SweepBudget:
    """How far one sweep may go, in counts: ``places`` looks at most, and ``actions`` planned
    for them at most (checked before each look; the look under way always finishes)."""

    places: int = 12
    actions: int = 100

    def __post_init__(self) -> None:
        if self.places < 1:
            raise ValueError(f"a sweep searches at least 1 place, got {self.places}")
        if self.actions < 1:
            raise ValueError(f"a sweep plans at least 1 action, got {self.actions}")

    def describe(self) -> str:
        return f"at most {self.places} places, {self.actions} actions"


@dataclass
class Sweep:
    """One consultation's search for ``obj``: the looks still to make (``order``), those made
    (``made``) and the actions planned for them (``actions``)."""

    obj: str
    order: list[Literal]
    budget: SweepBudget
    made: list[Literal] = field(default_factory=list)
    passed: list[str] = field(default_factory=list)  # looks passed over, and why
    actions: int = 0

    def over(self) -> str:
        """Why the sweep may make no more looks ("" while it may)."""
        if len(self.made) >= self.budget.places:
            return f"the budget's {self.budget.places} places are searched"
        if self.actions >= self.budget.actions:
            return f"the budget's {self.budget.actions} actions are planned"
        return ""

    def candidates(self, exhausted: Iterable[Literal]) -> list[Literal]:
        """The looks still to make, in order, less the places searched in vain."""
        vain = {str(g) for g in exhausted}
        left = []
        for g in self.order:
            if str(g) in vain:
                self.passed.append(f"{g}: searched before")
            else:
                left.append(g)
        self.order = left
        return list(left)

    def take(self, look: Literal, actions: int) -> None:
        """``look`` is made, with a plan of ``actions`` steps."""
        self.order = [g for g in self.order if g != look]
        self.made.append(look)
        self.actions += actions

    def note(self) -> str:
        """The page's line for the look just made."""
        n = len(self.made)
        order = " ".join(map(str, [*self.made, *self.order]))
        return (
            f"sweep for {self.obj}: look {n} of {order} "
            f"(budget {self.budget.describe()}; stops when {self.obj} is seen)"
        )


def ordered(first: Iterable[Literal], rest: Iterable[Literal]) -> list[Literal]:
    """The looks of ``first`` then of ``rest``, each once, in order."""
    out: list[Literal] = []
    for g in (*first, *rest):
        if g not in out:
            out.append(g)
    return out


__all__ = ["Sweep", "SweepBudget", "ordered"]
