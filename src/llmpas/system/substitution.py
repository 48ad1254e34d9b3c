"""Substitution keeps the rest of the task. When a task's literal cannot be made true for a
cause the robot knows (a fact of its belief that an action needs false and that no action
changes: a jammed door, a broken object) and a recovery goal makes the same predicate true for
the same object elsewhere (or for another object of the same kind), the loop carries the
substitute into the task (:func:`substitution`) and still pursues every other part; the run
ends done when the substituted task holds, and the page says what was substituted and why.
With no known cause, no substitution: the task stays as it was given.

"Of the same kind": the same unary facts that never change (``(Drawer drawer1)``,
``(Object mug)``) in the facts the planner plans from. Both rules read the domain's action
schemas, never a world's names.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence, Set
from dataclasses import dataclass

from llmpas.language.domain import Domain
from llmpas.language.logic import And, Atom, Formula, Not, conjuncts, effect_atoms
from llmpas.reasoning.goal_reading import Literal


@dataclass(frozen=True)
class Substitution:
    """``replaced``, a task literal, by ``by``; ``cause``: the belief's fact that forbids it."""

    replaced: Atom
    by: Atom
    cause: Atom

    def describe(self) -> str:
        return (
            f"{self.replaced} replaced by {self.by}: {self.cause} holds in the belief, an "
            "action needs it false, and no action changes it"
        )


@dataclass(frozen=True)
class Causes:
    """What the domain says can block a task for good: ``blocking``, the predicates no action
    changes that some action's precondition needs false; ``static``, every predicate no action
    changes (and none derived)."""

    blocking: frozenset[str]
    static: frozenset[str]

    @classmethod
    def of(cls, domain: Domain) -> Causes:
        effects = [a for act in domain.actions for _, a in effect_atoms(act.effects)]
        changed = {a.predicate.lower() for a in effects}
        derived = {d.head.name.lower() for d in domain.derived}
        static = frozenset(p.lower() for p in domain.predicates) - changed - derived
        blocking = {
            c.arg.predicate.lower()
            for act in domain.actions
            for c in conjuncts(act.precondition)
            if isinstance(c, Not) and isinstance(c.arg, Atom) and c.arg.predicate.lower() in static
        }
        return cls(frozenset(blocking), static)


def substitution(
    task: Formula, goals: Sequence[Literal], facts: Set[Atom], causes: Causes
) -> Substitution | None:
    """The first goal of ``goals`` that substitutes a literal of ``task`` whose argument a
    blocking fact of ``facts`` names (None: no such goal, or no known cause)."""
    parts = [c for c in conjuncts(task) if isinstance(c, Atom)]
    known = [f for f in facts if f.predicate.lower() in causes.blocking]
    for g in goals:
        if not isinstance(g, Atom) or g in parts:
            continue
        for t in parts:
            arg = _differs(t, g)
            if arg is None or (arg == 0 and not _same_kind(t.args[0], g.args[0], facts, causes)):
                continue
            cause = next((f for f in sorted(known) if t.args[arg] in f.args), None)
            if cause is not None:
                return Substitution(t, g, cause)
    return None


def substitutes(
    task: Formula, facts: Set[Atom], causes: Causes, objects: Iterable[str]
) -> list[Atom]:
    """The goals that would substitute a task literal a known cause blocks: for each task atom
    with an argument that a blocking fact of ``facts`` names (``(on box drawer2)`` with
    ``(jammed drawer2)``), the same atom with that argument replaced by another object of the
    same kind that no blocking fact names (``(on box drawer1)``), in the task's order, then the
    objects'. What :func:`substitution` carries into the task, offered as candidates."""
    parts = [c for c in conjuncts(task) if isinstance(c, Atom)]
    blocked = {a for f in facts if f.predicate.lower() in causes.blocking for a in f.args}
    out: list[Atom] = []
    for t in parts:
        for i, arg in enumerate(t.args):
            if arg not in blocked:
                continue
            for o in sorted(set(objects) - blocked):
                if _same_kind(arg, o, facts, causes):
                    g = Atom(t.predicate, (*t.args[:i], o, *t.args[i + 1 :]))
                    if g not in out and g not in parts:
                        out.append(g)
    return out


def substituted(task: Formula, s: Substitution) -> Formula:
    """``task`` with its literal ``s.replaced`` replaced by ``s.by``."""
    return And(tuple(s.by if c == s.replaced else c for c in conjuncts(task)))


def _differs(t: Atom, g: Atom) -> int | None:
    """The one argument ``g`` differs from ``t`` in (same predicate), else None."""
    if t.predicate.lower() != g.predicate.lower() or len(t.args) != len(g.args):
        return None
    diff = [i for i, (a, b) in enumerate(zip(t.args, g.args, strict=True)) if a != b]
    return diff[0] if len(diff) == 1 else None


def _same_kind(a: str, b: str, facts: Iterable[Atom], causes: Causes) -> bool:
    def kind(o: str) -> frozenset[str]:
        return frozenset(
            f.predicate.lower()
            for f in facts
            if f.args == (o,)
            and f.predicate.lower() in causes.static
            and f.predicate.lower() not in causes.blocking
        )

    return bool(kind(a)) and kind(a) == kind(b)


__all__ = ["Causes", "Substitution", "substituted", "substitutes", "substitution"]
