"""Compile a TAMP problem state into a classical PDDL task for Fast Downward.

Real facts and the certified facts of every optimistic stream instance (placeholder outputs
``#oN``) go to ``:init``; the classical planner then plans as if every stream succeeded. Which
optimistic facts a plan relies on is found afterwards from its preimage
(:func:`llmpas.language.semantics.preimage`), not by searching over stream actions (whose
commutative orderings make the search space explode).

Negated atoms of test streams are rewritten to ``rejected__P`` facts: true only for bindings a test
has rejected (before a test is evaluated it is optimistically assumed to pass). ``rejected__P`` is
declared for every test predicate, and a task's init keeps only the rejections the domain reads.
Fast Downward wants integer costs: every cost is multiplied by ``COST_SCALE`` and rounded.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from llmpas.language.bindings import BoundFunction, BoundStream
from llmpas.language.domain import Action, Derived, Domain, Signature
from llmpas.language.logic import (
    And,
    Atom,
    EffectItem,
    Exists,
    Forall,
    ForallEffect,
    Formula,
    FuncTerm,
    Increase,
    Not,
    Or,
    Param,
    Substitution,
    When,
    atoms_of,
    conjuncts,
    effect_atoms,
)
from llmpas.language.problem import Problem
from llmpas.language.semantics import State, nnf
from llmpas.language.streams import StreamSchema
from llmpas.planning.downward import ClassicalTask
from llmpas.planning.externals import external_rewrite
from llmpas.planning.fluents import block_uses, fluent_additions
from llmpas.planning.instances import (
    OptInstance,
    StreamFailure,
    is_optimistic,
    join,
    rejected_predicate,
)

COST_SCALE = 100

#: One classical task: the problem as data; its PDDL text is ``.text``.
Task = ClassicalTask


def is_rejection(a: Atom) -> bool:
    return a.predicate.startswith(rejected_predicate(""))


def _scaled(x: float) -> int:
    return max(0, round(x * COST_SCALE))


def _rewrite(f: Formula, negative_tests: set[str], external: Mapping[str, str]) -> Formula:
    """NNF, with ``(not (P ...))`` of a test predicate P replaced by ``(rejected__P ...)``
    (after external predicates were replaced by their complements)."""
    return _rw(nnf(external_rewrite(f, external)), negative_tests)


def _rw(f: Formula, neg: set[str]) -> Formula:
    match f:
        case Not(Atom() as a) if a.predicate in neg:
            return Atom(rejected_predicate(a.predicate), a.args)
        case And(parts):
            return And(tuple(_rw(p, neg) for p in parts))
        case Or(parts):
            return Or(tuple(_rw(p, neg) for p in parts))
        case Exists(ps, body):
            return Exists(ps, _rw(body, neg))
        case Forall(ps, body):
            return Forall(ps, _rw(body, neg))
    return f


def _effects(
    effects: tuple[EffectItem, ...], neg: set[str], ext: Mapping[str, str], unit: bool
) -> tuple[EffectItem, ...]:
    out: list[EffectItem] = []
    for e in effects:
        match e:
            case When(cond, effs):
                out.append(When(_rewrite(cond, neg, ext), _effects(effs, neg, ext, False)))
            case ForallEffect(ps, effs):
                out.append(ForallEffect(ps, _effects(effs, neg, ext, False)))
            case Increase(float() | int() as x):
                out.append(Increase(float(_scaled(x))))
            case _:
                out.append(e)
    if unit:
        out.append(Increase(float(COST_SCALE)))
    return tuple(out)


@dataclass(frozen=True)
class Inlined:
    """A deferred stream compiled into an action: its certified atom in the precondition was
    replaced by the stream's ``:domain``, and its output parameters were dropped."""

    stream: str
    inputs: tuple[str, ...]  # action terms feeding the stream's inputs
    outputs: tuple[str, ...]  # the dropped action parameters, in stream output order
    certified: tuple[Atom, ...]  # the stream's certified atoms over action terms


@dataclass(frozen=True)
class CompiledDomain:
    domain: Domain
    text: str
    # action name -> (original parameters, inlined deferred streams)
    inlined: Mapping[str, tuple[tuple[Param, ...], tuple[Inlined, ...]]] = field(
        default_factory=dict
    )

    def expand(
        self, name: str, args: tuple[str, ...], fresh: Callable[[], str]
    ) -> tuple[tuple[str, ...], list[tuple[Inlined, dict[str, str]]]]:
        """The original arguments of a compiled action (dropped outputs get fresh placeholders)
        and its inlined stream uses with their ground substitution."""
        if name not in self.inlined:
            return args, []
        original, uses = self.inlined[name]
        compiled = [p for p in original if all(p.name not in u.outputs for u in uses)]
        env = dict(zip((p.name for p in compiled), args, strict=True))
        for u in uses:
            for o in u.outputs:
                env[o] = fresh()
        return tuple(env[p.name] for p in original), [(u, env) for u in uses]


def inlinable_streams(problem: Problem, deferred: frozenset[str]) -> frozenset[str]:
    """Deferred streams that need no instances: their outputs feed no stream, and their certified
    predicates are certified by no other stream and used only positively in action
    preconditions (top-level conjuncts), never in derived predicates, effects or the goal."""
    out = set()
    certified_by: dict[str, set[str]] = {}
    for b in problem.bound_streams.values():
        for a in b.schema.certified:
            certified_by.setdefault(a.predicate, set()).add(b.schema.name)
    stream_domains = {a.predicate for b in problem.bound_streams.values() for a in b.schema.domain}
    d = problem.domain
    elsewhere = {a.predicate for x in d.derived for a in atoms_of(x.body)}
    elsewhere |= {a.predicate for a in atoms_of(problem.goal)}
    for act in d.actions:
        elsewhere |= {a.predicate for _, a in effect_atoms(act.effects)}
        top = {c for c in conjuncts(act.precondition) if isinstance(c, Atom)}
        elsewhere |= {a.predicate for a in atoms_of(act.precondition) if a not in top}
    for name in deferred:
        schema = problem.bound_streams[name].schema
        preds = {a.predicate for a in schema.certified}
        if any(certified_by[p] != {name} for p in preds) or preds & (elsewhere | stream_domains):
            continue
        if schema.outputs and all(_outputs_private(act, schema) for act in d.actions):
            out.add(name)
    return frozenset(out)


def _outputs_private(act: Action, schema: StreamSchema) -> bool:
    """In ``act``, the stream's output variables are parameters used only in its atoms."""
    preds = {a.predicate for a in schema.certified}
    mine = [c for c in conjuncts(act.precondition) if isinstance(c, Atom) and c.predicate in preds]
    if not mine:
        return True
    outs = _output_terms(mine, schema)
    if outs is None:
        return False
    params = {p.name for p in act.params}
    others = [a for a in atoms_of(act.precondition) if a not in mine]
    used = {t for a in others for t in a.args} | {
        t for _, a in effect_atoms(act.effects) for t in a.args
    }
    return all(o in params and o not in used for o in outs)


def _output_terms(atoms: list[Atom], schema: StreamSchema) -> tuple[str, ...] | None:
    """Match the stream's certified atoms to the action's: the terms standing for its outputs."""
    env: dict[str, str] = {}
    for a in atoms:
        pattern = next((c for c in schema.certified if c.predicate == a.predicate), None)
        if pattern is None:
            return None
        for v, t in zip(pattern.args, a.args, strict=True):
            if env.setdefault(v, t) != t:
                return None
    if any(o not in env for o in schema.outputs):
        return None
    return tuple(env[o] for o in schema.outputs)


def _inline(act: Action, schemas: list[StreamSchema]) -> tuple[Action, tuple[Inlined, ...]]:
    uses: list[Inlined] = []
    parts = list(conjuncts(act.precondition))
    for schema in schemas:
        preds = {a.predicate for a in schema.certified}
        mine = [c for c in parts if isinstance(c, Atom) and c.predicate in preds]
        if not mine:
            continue
        env: dict[str, str] = {}
        for a in mine:
            pattern = next(c for c in schema.certified if c.predicate == a.predicate)
            env.update(zip(pattern.args, a.args, strict=True))
        sub = Substitution(env)
        parts = [c for c in parts if c not in mine] + [sub.atom(x) for x in schema.domain]
        uses.append(
            Inlined(
                schema.name,
                tuple(env[v] for v in schema.inputs),
                tuple(env[v] for v in schema.outputs),
                tuple(sub.atom(x) for x in schema.certified),
            )
        )
    dropped = {o for u in uses for o in u.outputs}
    params = tuple(p for p in act.params if p.name not in dropped)
    return replace(act, params=params, precondition=And(tuple(parts))), tuple(uses)


def compile_domain(
    problem: Problem,
    negative_tests: set[str],
    inline: frozenset[str] = frozenset(),
    fluent: Mapping[str, BoundStream] | None = None,
) -> CompiledDomain:
    """The domain as Fast Downward gets it; the same for every iteration of a planning run.

    Streams in ``inline`` (see :func:`inlinable_streams`) are compiled into the actions. The
    uses of what the ``fluent`` streams certify get their blocks (:mod:`.fluents`)."""
    fluent = fluent or {}
    d = problem.domain
    unit = not d.uses_costs()
    schemas = [problem.bound_streams[n].schema for n in sorted(inline)]
    inlined: dict[str, tuple[tuple[Param, ...], tuple[Inlined, ...]]] = {}
    ext = problem.streams.external_predicates
    actions = []
    for a in d.actions:
        new, uses = _inline(a, schemas)
        if uses:
            inlined[a.name] = (a.params, uses)
        actions.append(
            replace(
                new,
                precondition=block_uses(_rewrite(new.precondition, negative_tests, ext), fluent),
                effects=_effects(new.effects, negative_tests, ext, unit),
            )
        )
    derived = tuple(
        replace(x, body=block_uses(_rewrite(x.body, negative_tests, ext), fluent))
        for x in d.derived
    )
    certified = problem.streams.certified_predicates
    preds = [Signature(name, _vars(arity)) for name, arity in certified.items()]
    # every test's rejections are declared, however (or whether) the domain uses its predicate
    preds += [
        Signature(rejected_predicate(p), _vars(certified[p]))
        for p in sorted(problem.streams.test_predicates)
    ]
    extra: list[Derived] = []
    if fluent:
        more, extra = fluent_additions(d, fluent)
        preds += more
    out = replace(d, actions=tuple(actions), derived=derived, undeclared={}).with_additions(
        predicates=preds, derived=extra
    )
    return CompiledDomain(out, out.to_pddl(), inlined)


def _vars(n: int) -> tuple[Param, ...]:
    return tuple(Param(f"?x{i}") for i in range(n))


def function_values(
    problem: Problem,
    facts: Iterable[Atom],
    cache: dict[FuncTerm, float],
    value: Callable[[str], Any],
    optimistic_cost: float = 1.0,
) -> dict[FuncTerm, float]:
    """Values of every ``:function`` on the bindings its domain allows, plus the problem's costs.

    ``value(name)`` gives an object's Python value (stream outputs included)."""
    out = dict(problem.costs)
    state = State(facts)
    for f in problem.bound_functions.values():
        out.update(_function_values(f, state, value, cache, optimistic_cost))
    return out


def _function_values(
    f: BoundFunction,
    state: State,
    value: Callable[[str], Any],
    cache: dict[FuncTerm, float],
    default: float,
) -> dict[FuncTerm, float]:
    out: dict[FuncTerm, float] = {}
    head = f.schema.head
    for env in join(f.schema.domain, state):
        term = FuncTerm(head.predicate, Substitution(env).atom(head).args)
        if any(is_optimistic(a) for a in term.args):
            values = tuple(None if is_optimistic(a) else value(a) for a in term.args)
            out[term] = _guarded(term, f.optimistic, values, default)
            continue
        if term not in cache:
            cache[term] = _guarded(term, f.value, tuple(value(a) for a in term.args))
        out[term] = cache[term]
    return out


def _guarded(term: FuncTerm, fn: Callable[..., float], *args: Any) -> float:
    try:
        return fn(*args)
    except Exception as e:  # a user's cost function failed: say which term
        raise StreamFailure(f"function {term} raised {type(e).__name__}: {e}") from e


def external_facts(problem: Problem, rejected: Iterable[Atom]) -> set[Atom]:
    """``(P ...)`` for every external predicate P its implementation said True for (its
    complement's test was rejected): what the original domain reads."""
    by_rejection = {
        rejected_predicate(c): p for p, c in problem.streams.external_predicates.items()
    }
    return {
        Atom(by_rejection[a.predicate], a.args) for a in rejected if a.predicate in by_rejection
    }


def compile_goal(problem: Problem, negative_tests: set[str]) -> Formula:
    """The goal as the compiled domain reads it (test rejections, external predicates)."""
    return _rewrite(problem.goal, negative_tests, problem.streams.external_predicates)


def compile_task(
    problem: Problem,
    facts: Iterable[Atom],
    optimistic: Iterable[OptInstance],
    costs: Mapping[FuncTerm, float],
    object_types: Mapping[str, str],
    negative_tests: set[str],
) -> Task:
    """The classical problem as data (its PDDL text is ``.text``): objects and init sorted,
    ``(= (total-cost) 0)`` and the scaled costs, the compiled goal."""
    wanted = {rejected_predicate(p) for p in negative_tests}
    init = {a for a in facts if a.predicate in wanted or not is_rejection(a)}
    init |= {a for i in optimistic for a in i.certified}
    objects = dict(object_types)
    for a in init:
        for t in a.args:
            objects.setdefault(t, "object")
    constants = {c.name for c in problem.domain.constants}
    values: list[tuple[str, tuple[str, ...], int]] = [("total-cost", (), 0)]  # every action costs
    values += [(t.name, t.args, _scaled(v)) for t, v in sorted(costs.items(), key=str)]
    return Task(
        problem.name,
        problem.domain.name,
        tuple((o, t) for o, t in sorted(objects.items()) if o not in constants),
        tuple((a.predicate, a.args) for a in sorted(init)),
        tuple(values),
        str(compile_goal(problem, negative_tests)),
    )


__all__ = [
    "COST_SCALE",
    "CompiledDomain",
    "Task",
    "compile_domain",
    "compile_goal",
    "compile_task",
    "external_facts",
    "function_values",
]
