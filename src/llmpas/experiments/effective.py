"""Effective goal sets: whether a proposal resolves the anomaly, judged on the goals themselves.

A task file lists, under ``[judge] effective``, the goal sets an expert would accept as resolving
its anomaly (each a PDDL conjunction of goal literals, read exactly as an LLM's answer is). The
judge then reports, per method, the share of FIRST proposals that are effective, beside the
end-to-end SR: replanning the task from the belief often resolves an anomaly whatever the LLM said
(the cause is already in the belief), so SR alone cannot tell reasoning from none.

**The rule.** The *first proposal* of a run is the first goal answer of its first LLM consultation
(before any feedback or repair), read with the method's reader. It is *effective* when it
entails one of the task's sets; it entails a set when it covers every literal of the set:

- a literal covers itself;
- ``(on X B)`` and ``(holding X)`` cover ``(not (on X A))`` for every ``A != B`` (an object is in
  one place at a time);
- *modulo the loop's rewrite*: for the object an object-loss anomaly lost (its failed
  ``(on X R)``), ``(on X P)`` with ``P`` a place the robot can search is read as ``(scanned P)``
  (the loop reads it as that hypothesis: look at ``P``), on both sides.

Extra literals in the proposal do not matter (planning the task again adds them anyway); an
answer that does not parse, or a run without an LLM consultation, is not effective.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence

from llmpas.language.logic import Atom, Formula, Not
from llmpas.reasoning.goal_reading import GoalStatus, Literal, parse_goals
from llmpas.reasoning.tables import Vocabulary


class EffectiveSetError(ValueError):
    """An effective set that is not a conjunction of goal literals of the task's vocabulary."""


def parse_set(text: str, vocab: Vocabulary) -> tuple[Literal, ...]:
    """The literals of one effective set (read as an LLM answer is; EffectiveSetError: why)."""
    if not isinstance(text, str) or not text.strip():
        raise EffectiveSetError(f"must be PDDL text, got {text!r}")
    parse = parse_goals(text, vocab)
    if parse.status is not GoalStatus.OK:
        raise EffectiveSetError(f"{text!r}: " + "; ".join(parse.errors))
    if parse.source.strip() != text.strip():
        raise EffectiveSetError(f"{text!r}: must be only the conjunction, not {parse.source!r}")
    return parse.goals


def lost_object(constraint: Formula | None) -> str | None:
    """The object an object-loss anomaly lost: ``X`` of a failed ``(on X R)``; else None."""
    if isinstance(constraint, Atom) and constraint.predicate == "on" and constraint.args:
        return constraint.args[0]
    return None


def as_search(literal: Literal, lost: str | None, places: Collection[str]) -> Literal:
    """``(scanned P)`` for ``(on LOST P)`` with ``P`` a search place, as the loop reads it."""
    if (
        lost is not None
        and isinstance(literal, Atom)
        and literal.predicate == "on"
        and literal.args[0] == lost
        and literal.args[1] in places
    ):
        return Atom("scanned", (literal.args[1],))
    return literal


def covers(goals: Collection[Literal], literal: Literal) -> bool:
    """Whether the proposal's literals ``goals`` cover one literal of a set (see the rule)."""
    if literal in goals:
        return True
    if isinstance(literal, Not) and isinstance(literal.arg, Atom):
        atom = literal.arg
        if atom.predicate == "on" and len(atom.args) == 2:
            obj, away = atom.args
            for g in goals:
                if not isinstance(g, Atom) or not g.args or g.args[0] != obj:
                    continue
                if g.predicate == "holding" or (g.predicate == "on" and g.args[1] != away):
                    return True
    return False


def entails(
    goals: Iterable[Literal],
    required: Iterable[Literal],
    lost: str | None = None,
    places: Collection[str] = (),
) -> bool:
    """Whether a proposal entails one effective set (every literal of it is covered)."""
    have = {as_search(g, lost, places) for g in goals}
    return all(covers(have, as_search(r, lost, places)) for r in required)


def is_effective(
    goals: Iterable[Literal],
    sets: Sequence[Sequence[Literal]],
    lost: str | None = None,
    places: Collection[str] = (),
) -> bool:
    """Whether a proposal entails at least one of the effective ``sets``."""
    goals = tuple(goals)
    return bool(goals) and any(entails(goals, s, lost, places) for s in sets)


__all__ = [
    "EffectiveSetError",
    "as_search",
    "covers",
    "entails",
    "is_effective",
    "lost_object",
    "parse_set",
]
