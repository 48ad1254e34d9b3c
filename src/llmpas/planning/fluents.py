"""Fluent streams (``:fluents`` in a stream declaration), as PDDLStream defines them.

A fluent stream's implementation gets, besides its inputs, the facts of its ``:fluents``
predicates that hold in the state where its output is used (``fluents=[...]``): a motion
planner that avoids the objects where they are *then*. While planning (focused):

- its instances are assumed like any other's, in every state (its output is a placeholder);
- once a plan relies on one, the instance is evaluated once per step that uses it, with the
  fluent facts of the state before that step (the plan's real values bound first): its real
  facts hold only in that *context* (:class:`~llmpas.planning.instances.StreamStore` keeps
  them apart from the other real facts, and checks them per step when a plan is replayed);
- when it fails in a context, the instance is *blocked* in every state where the facts of that
  context hold (a superset of them), until a search fails and everything is re-enabled, as in
  PDDLStream's adaptive algorithm; when it can give nothing more there (a function or test
  answered, a generator ended), it is also blocked for good in the states whose fluent facts
  are exactly those (so that a search does not plan the same failure again and again).
  In the classical task a block is an object ``#cN`` with static facts
  ``(ctxof__S #cN inputs...)`` (or ``ctxexact__S`` for an exact one) and
  ``(ctx__P #cN args...)`` per fluent fact; the domain derives ``(blocked__S inputs...)``
  when one of the instance's blocks applies, and every positive use of the stream's certified
  predicate requires it false.

What stays unsupported is refused in one line by :func:`unsupported_fluents`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from llmpas.language.bindings import BoundStream
from llmpas.language.domain import Derived, Domain, Signature
from llmpas.language.logic import (
    And,
    Atom,
    Exists,
    Forall,
    Formula,
    Not,
    Or,
    Param,
    atoms_of,
    effect_atoms,
)
from llmpas.language.problem import Problem
from llmpas.planning import planner_registry

BLOCKED_PREFIX = "blocked__"
CONTEXT_PREFIX = "ctx__"
CONTEXT_OF_PREFIX = "ctxof__"
CONTEXT_EXACT_PREFIX = "ctxexact__"
CONTEXT_EXTRA_PREFIX = "ctxextra__"
CONTEXT_MISSING = "ctxmissing__"
CONTEXT_OBJECT = "#c"


def fluent_streams(problem: Problem, deferred: Iterable[str] = ()) -> dict[str, BoundStream]:
    """The streams with ``:fluents`` that are evaluated while planning (not deferred)."""
    skip = set(deferred)
    return {
        n: b
        for n, b in problem.bound_streams.items()
        if b.schema.fluents and b.schema.kind == "stream" and n not in skip
    }


def context(facts: Iterable[Atom], fluents: Iterable[str]) -> frozenset[Atom]:
    """The facts of the ``fluents`` predicates among ``facts``."""
    preds = set(fluents)
    return frozenset(a for a in facts if a.predicate in preds)


def unsupported_fluents(
    problem: Problem, algorithm: str, deferred: Iterable[str] = (), negated: Iterable[str] = ()
) -> str | None:
    """One line naming the first fluent-stream construct this planner does not plan, or None.

    ``negated``: the test predicates that occur negated in the domain or goal."""
    streams = fluent_streams(problem, deferred)
    if not streams:
        return None
    first = sorted(streams)[0]
    if "fluents" not in planner_registry.algorithm(algorithm).supports:
        return (
            f"stream {first!r}: ':fluents' needs the focused algorithm (adaptive, focused, "
            f"binding), not {algorithm!r}"
        )
    declared = problem.domain.predicates
    derived = problem.domain.derived_names
    owner: dict[str, str] = {}
    for name, b in sorted(streams.items()):
        s = b.schema
        if b.info.never_assumed or b.info.eager:
            return (
                f"stream {name!r}: ':fluents' on a stream evaluated before search "
                "(eager, p_success=0)"
            )
        for p in s.fluents:
            if p not in declared and p not in derived:
                return f"stream {name!r}: ':fluents ({p})' names no predicate of the domain"
        for a in s.certified:
            other = owner.setdefault(a.predicate, name)
            if other != name:
                return (
                    f"predicate {a.predicate!r} is certified by two streams with ':fluents' "
                    f"({other!r}, {name!r})"
                )
            if a.predicate in set(negated):
                return (
                    f"stream {name!r}: ':fluents' on a test whose ({a.predicate} ...) occurs "
                    "negated"
                )
    for other_name in sorted(problem.bound_streams):
        for a in problem.bound_streams[other_name].schema.domain:
            if a.predicate in owner and other_name != owner[a.predicate]:
                return (
                    f"stream {owner[a.predicate]!r}: ':fluents', and its certified "
                    f"({a.predicate} ...) is in the :domain of {other_name!r}: outputs of fluent "
                    "streams feeding other streams"
                )
    for act in problem.domain.actions:
        for _, a in effect_atoms(act.effects):
            if a.predicate in owner:
                return (
                    f"action {act.name!r}: an effect on ({a.predicate} ...), certified by stream "
                    f"{owner[a.predicate]!r} with ':fluents'"
                )
    return None


def _vars(n: int) -> tuple[Param, ...]:
    return tuple(Param(f"?x{i}") for i in range(n))


def fluent_additions(
    domain: Domain, streams: Mapping[str, BoundStream]
) -> tuple[list[Signature], list[Derived]]:
    """The predicates and derived predicates of blocks (module docstring)."""
    preds: list[Signature] = []
    derived: list[Derived] = []
    fluent_preds = sorted({p for b in streams.values() for p in b.schema.fluents})
    c = Param("?c")
    missing: list[Formula] = []
    for p in fluent_preds:
        arity = _arity(domain, p)
        preds.append(Signature(CONTEXT_PREFIX + p, (c, *_vars(arity))))
        xs = _vars(arity)
        names = tuple(x.name for x in xs)
        body: Formula = And((Atom(CONTEXT_PREFIX + p, ("?c", *names)), Not(Atom(p, names))))
        missing.append(Exists(xs, body) if xs else body)
    derived.append(Derived(Signature(CONTEXT_MISSING, (c,)), Or(tuple(missing))))
    arities = {p: _arity(domain, p) for p in fluent_preds}
    for name, b in sorted(streams.items()):
        extra: list[Formula] = []
        for p in sorted(set(b.schema.fluents)):
            ys = _vars(arities[p])
            ns = tuple(y.name for y in ys)
            body = And((Atom(p, ns), Not(Atom(CONTEXT_PREFIX + p, ("?c", *ns)))))
            extra.append(Exists(ys, body) if ys else body)
        derived.append(Derived(Signature(CONTEXT_EXTRA_PREFIX + name, (c,)), Or(tuple(extra))))
        xs = _vars(len(b.schema.inputs))
        names = tuple(x.name for x in xs)
        preds.append(Signature(CONTEXT_OF_PREFIX + name, (c, *xs)))
        preds.append(Signature(CONTEXT_EXACT_PREFIX + name, (c, *xs)))
        complete = Not(Atom(CONTEXT_MISSING, ("?c",)))
        superset = And((Atom(CONTEXT_OF_PREFIX + name, ("?c", *names)), complete))
        exact = And(
            (
                Atom(CONTEXT_EXACT_PREFIX + name, ("?c", *names)),
                complete,
                Not(Atom(CONTEXT_EXTRA_PREFIX + name, ("?c",))),
            )
        )
        derived.append(
            Derived(Signature(BLOCKED_PREFIX + name, xs), Exists((c,), Or((superset, exact))))
        )
    return preds, derived


def _arity(domain: Domain, predicate: str) -> int:
    if predicate in domain.predicates:
        return len(domain.predicates[predicate].params)
    for d in domain.derived:
        if d.head.name == predicate:
            return len(d.head.params)
    raise KeyError(predicate)


def block_uses(f: Formula, streams: Mapping[str, BoundStream]) -> Formula:
    """``f`` (in negation normal form) with every positive atom of a fluent stream's certified
    predicate ``P`` conjoined with ``(not (blocked__S inputs...))``, the inputs read off the
    atom (when the certified atom names them all)."""
    patterns = {
        a.predicate: (name, a, b.schema.inputs)
        for name, b in streams.items()
        for a in b.schema.certified
    }
    if not patterns:
        return f

    def walk(g: Formula) -> Formula:
        match g:
            case Atom(pred, args) if pred in patterns:
                name, pattern, inputs = patterns[pred]
                env = dict(zip(pattern.args, args, strict=True))
                if not all(v in env for v in inputs):
                    return g
                return And((g, Not(Atom(BLOCKED_PREFIX + name, tuple(env[v] for v in inputs)))))
            case And(parts):
                return And(tuple(walk(p) for p in parts))
            case Or(parts):
                return Or(tuple(walk(p) for p in parts))
            case Exists(ps, body):
                return Exists(ps, walk(body))
            case Forall(ps, body):
                return Forall(ps, walk(body))
        return g

    return walk(f)


_Blocks = Mapping[tuple[str, tuple[str, ...], frozenset[Atom]], str]


def block_facts(
    blocks: _Blocks, exact: _Blocks, hidden: set[str] | frozenset[str] = frozenset()
) -> set[Atom]:
    """The static facts of the active blocks (those naming no ``hidden`` object)."""
    out: set[Atom] = set()
    for kind, active in ((CONTEXT_OF_PREFIX, blocks), (CONTEXT_EXACT_PREFIX, exact)):
        for (name, inputs, ctx), obj in active.items():
            facts = {Atom(kind + name, (obj, *inputs))}
            facts |= {Atom(CONTEXT_PREFIX + a.predicate, (obj, *a.args)) for a in ctx}
            if all(hidden.isdisjoint(a.args) for a in facts):
                out |= facts
    return out


def certified_by_fluent(streams: Mapping[str, BoundStream]) -> dict[str, str]:
    """Predicate -> the fluent stream certifying it."""
    return {a.predicate: n for n, b in streams.items() for a in b.schema.certified}


def mentions(f: Formula, predicates: set[str]) -> bool:
    return any(a.predicate in predicates for a in atoms_of(f))


__all__ = [
    "BLOCKED_PREFIX",
    "CONTEXT_OBJECT",
    "block_facts",
    "block_uses",
    "certified_by_fluent",
    "context",
    "fluent_additions",
    "fluent_streams",
    "unsupported_fluents",
]
