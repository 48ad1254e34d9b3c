"""A search sweeps: the places one object-loss consultation yields, searched in order until the
lost object is seen, within a budget (places and seconds).

The order is the method's: a goal-writing method's looks in the order written; a choosing
method's chosen look, then the looks of the rest of its ranking, in rank order (for
``flp-choose``: every unsearched place the candidates hold, ranked by the model;
``candidates-first``: the enumeration's order; ``candidates-random``: its seeded shuffle). A
place searched in vain before is never searched again, a look no plan reaches is passed over,
and what every look saw stays in the belief (the loop never forgets it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from llmpas.reasoning.goals import Literal


@dataclass(frozen=True)
class SweepBudget:
    """How far one sweep may go: ``places`` looks at most, ``seconds`` since it began (checked
    before each look; the look under way always finishes)."""

    places: int = 12
    seconds: float = 300.0

    def __post_init__(self) -> None:
        if self.places < 1:
            raise ValueError(f"a sweep searches at least 1 place, got {self.places}")
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ValueError(f"a sweep's seconds must be a positive number, got {self.seconds}")

    def describe(self) -> str:
        return f"at most {self.places} places, {self.seconds:g} s"


@dataclass
class Sweep:
    """One consultation's search for ``obj``: the looks still to make (``order``), those made
    (``made``), from ``started`` on ``clock``."""

    obj: str
    order: list[Literal]
    budget: SweepBudget
    clock: Callable[[], float]
    started: float = 0.0
    made: list[Literal] = field(default_factory=list)
    passed: list[str] = field(default_factory=list)  # looks passed over, and why

    def __post_init__(self) -> None:
        self.started = self.clock()

    def over(self) -> str:
        """Why the sweep may make no more looks ("" while it may)."""
        if len(self.made) >= self.budget.places:
            return f"the budget's {self.budget.places} places are searched"
        if self.clock() - self.started >= self.budget.seconds:
            return f"the budget's {self.budget.seconds:g} s are spent"
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

    def take(self, look: Literal) -> None:
        self.order = [g for g in self.order if g != look]
        self.made.append(look)

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
