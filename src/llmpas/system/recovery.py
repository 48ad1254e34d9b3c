"""What the closed loop keeps from a recovery, apart from the round control itself
(:mod:`llmpas.system.next_goal`).

**Recovery goals stay achieved.** Once the loop has accepted the LLM's goals and achieved them,
later plans for the task keep them true (:func:`kept_goal`): they join the task's goal, except
those the task itself contradicts (``(not (on mug sink))`` against a task ``(on mug sink)``);
when the joined goal cannot be planned, the task is planned alone (it then needs them undone).
Without this, a goal reached by holding the occupant (``(not (on mug sink))``) was undone by the
next plan for the task, which put the occupant back where the appliance needed it gone.

**An order the LLM states is kept.** The literals of an answer are read in the order written
("first this, then that"). When the plan for all of them reaches a later literal before an
earlier one (:func:`out_of_order`: the occupant taken out only after the process that needed it
gone), the loop pursues them one at a time, in that order, each plan keeping the ones reached
before (:class:`Stages`). A plan that already respects the order is executed as it is, so an
answer whose order does not matter costs no extra round.

Measured on the defect's shape (tests/test_recovery.py, a sink that rinses one thing at a time
with a mug in it): with the answer "(not (on mug sink))" the task's next plan put the mug back
and every round failed; joined to the task, the mug goes to a table and the task succeeds. With
"(and (not (on mug sink)) (cleaned apple))" the joint plan rinsed first and failed every round;
in stages it succeeds. Fast Downward's plan constraints were not used: the planning layer has
no trajectory constraints, and the joined goal plus staging cover both shapes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics
from llmpas.planning.result import Plan
from llmpas.reasoning.goal_reading import Literal


def negation(g: Literal) -> Literal:
    return g.arg if isinstance(g, Not) else Not(g)  # type: ignore[return-value]


def conjuncts(f: Formula) -> tuple[Formula, ...]:
    """The parts of a conjunction (a formula that is none: itself)."""
    if isinstance(f, And):
        return tuple(p for part in f.parts for p in conjuncts(part))
    return (f,)


def kept_goal(
    task: Formula,
    kept: Sequence[Literal],
    new: Sequence[Literal] = (),
    conflicts: Conflicts | None = None,
) -> Formula:
    """``new`` goals, the task's conjuncts they do not contradict, and the ``kept`` recovery
    goals that neither contradicts, as one conjunction (in that order, without repeats).
    ``conflicts``: whether two literals cannot hold together (the domain's invariants): a new
    goal replaces the task's literal it is about (``(on mug table2)`` for the task's ``(on mug
    sink)`` in this round's goal), and a kept goal that conflicts with either is left out, so
    that no joined goal puts one object in two places."""
    clash = conflicts or _never
    parts: list[Formula] = list(new)
    banned = {negation(g) for g in new}
    for c in conjuncts(task):
        if c in banned or c in parts or any(clash(c, g) for g in new if _literal(c)):
            continue
        parts.append(c)
    banned |= {negation(c) for c in conjuncts(task) if isinstance(c, Atom | Not)}
    banned |= {Not(a) for a in atoms_of(task)}  # a task atom under a disjunction, say
    for k in dict.fromkeys(kept):
        if k in banned or k in parts or any(clash(k, p) for p in parts if _literal(p)):
            continue
        parts.append(k)
    return And(tuple(parts))


Conflicts = Callable[[Formula, Formula], bool]


def _never(a: Formula, b: Formula) -> bool:
    return False


def _literal(f: Formula) -> bool:
    return isinstance(f, Atom) or (isinstance(f, Not) and isinstance(f.arg, Atom))


def reached_at(
    sem: Semantics, problem: Problem, plan: Plan, goals: Sequence[Literal]
) -> list[int | None]:
    """For each goal, the index of the plan's state from which it holds to the end (0: the
    initial state; None: it does not hold at the end). States come from the actions' effects on
    the problem's facts and what the plan's streams certified."""
    facts = set(problem.init) | set(plan.certified)
    for assumed in plan.deferred_facts.values():
        facts |= set(assumed)
    holds = [[sem.holds(g, facts)] for g in goals]
    for step in plan.steps:
        action = sem.domain.action(step.action)
        facts, _ = sem.apply(action, step.args, sem.state(facts))
        state = sem.state(facts)
        for h, g in zip(holds, goals, strict=True):
            h.append(sem.holds(g, state))
    out: list[int | None] = []
    for h in holds:
        if not h[-1]:
            out.append(None)
            continue
        i = len(h) - 1
        while i > 0 and h[i - 1]:
            i -= 1
        out.append(i)
    return out


def out_of_order(sem: Semantics, problem: Problem, plan: Plan, goals: Sequence[Literal]) -> bool:
    """Whether the plan reaches a goal before one written earlier (for good: from where it
    holds to the end)."""
    if len(goals) < 2:
        return False
    at = reached_at(sem, problem, plan, goals)
    last = 0
    for t in at:
        if t is None:
            return False  # not a plan for these goals: nothing to say about their order
        if t < last:
            return True
        last = t
    return False


@dataclass
class Stages:
    """The recovery goals still to pursue, in the order the LLM wrote them, and those reached
    (kept true by every later plan of this run)."""

    kept: list[Literal] = field(default_factory=list)
    queue: list[Literal] = field(default_factory=list)

    def reached(self, goals: Iterable[Literal], conflicts: Conflicts | None = None) -> None:
        """``goals`` were reached: kept from now on, in place of the kept goals they
        contradict (the opposite literal, or one the domain's invariants exclude)."""
        clash = conflicts or _never
        for g in goals:
            self.kept = [k for k in self.kept if k != negation(g) and not clash(k, g)]
            if g not in self.kept:
                self.kept.append(g)


__all__ = [
    "Stages",
    "conjuncts",
    "kept_goal",
    "negation",
    "out_of_order",
    "reached_at",
]
