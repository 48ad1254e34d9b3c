"""Candidate recovery goal sets for the choosing methods (``flp-choose`` and its controls):
enumerated from the world's vocabulary, kept when the loop's own checks accept them.

**What is enumerated.** The anomaly's objects and places
(:meth:`~llmpas.system.anomaly_memory.Anomaly.objects`: the failed step's arguments, the failed
literal's, and the vocabulary's objects its reason names, ``lid lies over bowl``). Single
literals are every grounding of a goal predicate that names one of them, both polarities, and,
when one of them is lost, every look the vocabulary allows (``(scanned P)``); then conjunctions
of two surviving literals of different predicates that share an object.

**What is dropped**, cheapest test first: literals no action can make true
(:class:`~llmpas.system.achievable.Makeable`); literals already true; literals of the goal that
just failed (the failure would repeat); searches already made in vain. The planner-backed checks
of the loop's validator (:class:`~llmpas.system.goal_checks.GoalChecker`: repeated searches, already
true, unreachable, tried before) run on the ranking, best first, up to the first candidate they
accept exactly as it is (:func:`first_accepted`): the candidate proposed is the one that ranking
all accepted candidates would give, for far fewer planner calls. A literal that names none of the
anomaly's objects is never enumerated: it leaves the failed step as it was (a look at a place is
the exception, while an object is lost: finding it is what changes the step).

**Substitutes.** When a known cause blocks a task literal (``(on box drawer2)`` with ``(jammed
drawer2)``: a fact no action changes that an action needs false), the same literal with another
object of the same kind (:func:`~llmpas.system.substitution.substitutes`) is a candidate even
though it names none of the anomaly's objects: the loop carries it into the task.

The order is the looks first (while an object is lost), then the substitutes, then the
vocabulary's (predicates by name, groundings sorted, a literal before its negation), singles
before pairs: the ``candidates-first`` control proposes in this order.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence, Set

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Literal
from llmpas.reasoning.tables import Vocabulary

MAX_SINGLES = 36  # single literals ranked, at most
MAX_PAIRS = 6  # conjunctions of two ranked, at most
PAIRED = 12  # the first singles pairs are made of


def enumerate_goals(
    vocab: Vocabulary,
    anchors: Set[str],
    looks: Iterable[Literal],
    makeable: Callable[[Literal], bool],
    holds: Callable[[Literal], bool],
    failed: Set[str],
    excluded: Iterable[Literal] = (),
    read: Callable[[Literal], Literal] = lambda g: g,
    lost: Callable[[str], bool] = lambda name: False,
    conflicts: Callable[[Literal, Literal], bool] | None = None,
    substitutes: Iterable[Literal] = (),
) -> list[tuple[Literal, ...]]:
    """The candidate goal sets, in the enumeration's order (see the module's doc), after the
    cheap tests (makeable, not already true, not within the goal that just failed, not an
    exhausted search: ``excluded``, not naming a lost object: no plan acts on it before it is
    found; no pair ``conflicts`` excludes); ``substitutes`` (a blocked task literal with another
    place of the same kind) come right after the looks; each literal as the loop reads it
    (``read``: a lost object's place as a look); the planner-backed checks come after the
    ranking (:func:`first_accepted`)."""
    banned = set(excluded)
    # a lost object's looks come first, then the substitutes for a blocked task literal
    singles: list[Literal] = list(dict.fromkeys((*looks, *substitutes)))
    for predicate, allowed in vocab.predicates.items():
        for args in itertools.product(*map(sorted, allowed)):
            if anchors & set(args):
                atom = Atom(predicate, args)
                singles += [atom, Not(atom)]
    kept: list[Literal] = []
    for g in map(read, singles):
        if g in banned or g in kept or str(g) in failed or any(map(lost, _args(g))):
            continue
        if makeable(g) and not holds(g):
            kept.append(g)
    kept = kept[:MAX_SINGLES]
    pairs: list[tuple[Literal, ...]] = []
    for a, b in itertools.combinations(kept[:PAIRED], 2):
        if len(pairs) >= MAX_PAIRS:
            break
        if conflicts is not None and conflicts(a, b):
            continue  # the domain's invariants exclude the pair (one object in two places)
        if _predicate(a) != _predicate(b) and set(_args(a)) & set(_args(b)):
            pairs.append((a, b))
    return [(g,) for g in kept] + pairs


def first_accepted(
    check: Callable[[GoalParse], GoalParse], ranking: Sequence[tuple[Literal, ...]]
) -> tuple[int, tuple[Literal, ...]] | None:
    """The first candidate of ``ranking`` the validator accepts as it is (its index, and its
    goals as the validator reads them), or None. The checks run in rank order and stop at the
    first accepted: the same choice as checking every candidate before ranking (a candidate's
    score does not depend on the others'), at the cost of the planner calls up to it."""
    for i, goals in enumerate(ranking):
        got = accepted_as(check, goals)
        if got is not None:
            return i, got
    return None


def accepted_as(
    check: Callable[[GoalParse], GoalParse], goals: tuple[Literal, ...]
) -> tuple[Literal, ...] | None:
    """The goals as the validator takes them (a lost object's place read as a look), or None
    when it rejects or drops any of them."""
    out = check(GoalParse(GoalStatus.OK, goals, ()))
    if not out.ok or len(out.goals) != len(goals):
        return None
    return tuple(out.goals)


def _atom(g: Literal) -> Atom:
    a = g.arg if isinstance(g, Not) else g
    assert isinstance(a, Atom)
    return a


def _predicate(g: Literal) -> str:
    return _atom(g).predicate


def _args(g: Literal) -> Sequence[str]:
    return _atom(g).args


__all__ = [
    "MAX_PAIRS",
    "MAX_SINGLES",
    "accepted_as",
    "enumerate_goals",
    "first_accepted",
]
