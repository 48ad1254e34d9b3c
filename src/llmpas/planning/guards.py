"""Keep universally quantified preconditions from grounding over every object tuple.

Fast Downward's translator compiles a precondition ``(forall (?y) phi(?x, ?y))`` of an action into
an axiom ``new-axiom(?x) <- exists ?y: not phi`` and grounds it for *every* tuple of objects ``?x``,
because inside the axiom nothing restricts ``?x``. In PDDLStream-style domains (a ``place`` whose
``forall`` checks collisions against every other block's pose) that is objects^2 axiom heads, each
with every (block, pose) pair: 73,000 axioms for a 79-object task, most of translation time.

:func:`guard_quantifiers` rewrites such a conjunct into the negation of a derived predicate whose
body first requires the precondition's *static* atoms over the same parameters (facts no action
changes: certified stream facts, type-like predicates). On every state where the action is
applicable those atoms hold, so the rewritten precondition is equivalent; the derived predicate is
only grounded for parameter tuples the static facts allow.
"""

from __future__ import annotations

from dataclasses import replace

from llmpas.language.domain import Action, Derived, Domain, Signature
from llmpas.language.logic import (
    And,
    Atom,
    Exists,
    Forall,
    Formula,
    Imply,
    Not,
    Or,
    Param,
    conjuncts,
    effect_atoms,
)

GUARD_PREFIX = "forall__"


def guard_quantifiers(domain: Domain) -> Domain:
    """The domain with every guardable top-level ``forall`` precondition conjunct rewritten."""
    changed = {a.predicate for act in domain.actions for _, a in effect_atoms(act.effects)}
    changed |= {d.head.name for d in domain.derived}
    derived: list[Derived] = []
    actions: list[Action] = []
    for act in domain.actions:
        new, extra = _guard_action(act, changed)
        actions.append(new)
        derived += extra
    if not derived:
        return domain
    return replace(domain, actions=tuple(actions)).with_additions(derived=derived)


def _guard_action(act: Action, changed: set[str]) -> tuple[Action, list[Derived]]:
    parts = conjuncts(act.precondition)
    static = [c for c in parts if isinstance(c, Atom) and c.predicate not in changed]
    params = {p.name: p for p in act.params}
    out: list[Formula] = []
    derived: list[Derived] = []
    for k, part in enumerate(parts):
        rule = _guard(part, static, params, f"{GUARD_PREFIX}{act.name}__{k}")
        if rule is None:
            out.append(part)
            continue
        derived.append(rule)
        out.append(Not(Atom(rule.head.name, tuple(p.name for p in rule.head.params))))
    if not derived:
        return act, []
    return replace(act, precondition=And(tuple(out))), derived


def _guard(
    part: Formula, static: list[Atom], params: dict[str, Param], name: str
) -> Derived | None:
    """``name(free) <- static atoms over free (others existential) and exists y: not phi``."""
    if not isinstance(part, Forall):
        return None
    free = [v for v in params if v in free_variables(part)]
    guards = [a for a in static if set(a.args) & set(free)]
    covered = {t for a in guards for t in a.args}
    if not free or not guards or not set(free) <= covered:
        return None
    others = tuple(params[v] for v in params if v in covered and v not in free)
    guard: Formula = And(tuple(guards))
    if others:
        guard = Exists(others, guard)
    violated = Exists(part.params, Not(part.body))
    head = Signature(name, tuple(params[v] for v in free))
    return Derived(head, And((guard, violated)))


def free_variables(f: Formula) -> set[str]:
    """Variables (``?x``) occurring free in ``f``."""
    match f:
        case Atom(_, args):
            return {t for t in args if t.startswith("?")}
        case Not(arg):
            return free_variables(arg)
        case And(parts) | Or(parts):
            return set().union(*(free_variables(p) for p in parts))
        case Imply(c, t):
            return free_variables(c) | free_variables(t)
        case Exists(ps, body) | Forall(ps, body):
            return free_variables(body) - {p.name for p in ps}
    return set()


__all__ = ["GUARD_PREFIX", "free_variables", "guard_quantifiers"]
