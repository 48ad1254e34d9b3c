"""Compile a TAMP problem state into a classical PDDL task for Fast Downward.

Real facts and the certified facts of every optimistic stream instance (placeholder outputs
``#oN``) go to ``:init``; the classical planner then plans as if every stream succeeded. Which
optimistic facts a plan relies on is found afterwards from its preimage
(:func:`llmpas.language.semantics.preimage`), not by searching over stream actions (whose
commutative orderings make the search space explode).

Negated atoms of test streams are rewritten to ``rejected__P`` facts: true only for bindings a test
has rejected (before a test is evaluated it is optimistically assumed to pass).
Fast Downward wants integer costs: every cost is multiplied by ``COST_SCALE`` and rounded.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from llmpas.language.bindings import BoundFunction
from llmpas.language.domain import Domain, Signature
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
)
from llmpas.language.problem import Problem
from llmpas.language.semantics import State, nnf
from llmpas.planning.instances import (
    OptInstance,
    StreamFailure,
    is_optimistic,
    join,
    rejected_predicate,
)

COST_SCALE = 100


def _scaled(x: float) -> int:
    return max(0, round(x * COST_SCALE))


def _rewrite(f: Formula, negative_tests: set[str]) -> Formula:
    """NNF, with ``(not (P ...))`` of a test predicate P replaced by ``(rejected__P ...)``."""
    return _rw(nnf(f), negative_tests)


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


def _effects(effects: tuple[EffectItem, ...], neg: set[str], unit: bool) -> tuple[EffectItem, ...]:
    out: list[EffectItem] = []
    for e in effects:
        match e:
            case When(cond, effs):
                out.append(When(_rewrite(cond, neg), _effects(effs, neg, False)))
            case ForallEffect(ps, effs):
                out.append(ForallEffect(ps, _effects(effs, neg, False)))
            case Increase(float() | int() as x):
                out.append(Increase(float(_scaled(x))))
            case _:
                out.append(e)
    if unit:
        out.append(Increase(float(COST_SCALE)))
    return tuple(out)


@dataclass(frozen=True)
class CompiledDomain:
    domain: Domain
    text: str


def compile_domain(problem: Problem, negative_tests: set[str]) -> CompiledDomain:
    """The domain as Fast Downward gets it; the same for every iteration of a planning run."""
    d = problem.domain
    unit = not d.uses_costs()
    actions = tuple(
        replace(
            a,
            precondition=_rewrite(a.precondition, negative_tests),
            effects=_effects(a.effects, negative_tests, unit),
        )
        for a in d.actions
    )
    derived = tuple(replace(x, body=_rewrite(x.body, negative_tests)) for x in d.derived)
    certified = problem.streams.certified_predicates
    preds = [Signature(name, _vars(arity)) for name, arity in certified.items()]
    preds += [Signature(rejected_predicate(p), _vars(certified[p])) for p in sorted(negative_tests)]
    out = replace(d, actions=actions, derived=derived, undeclared={}).with_additions(
        predicates=preds
    )
    return CompiledDomain(out, out.to_pddl())


def _vars(n: int) -> tuple[Param, ...]:
    return tuple(Param(f"?x{i}") for i in range(n))


@dataclass(frozen=True)
class Task:
    """One classical task: the problem text."""

    problem_text: str


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
            out[term] = default
            continue
        if term not in cache:
            try:
                cache[term] = f.value(tuple(value(a) for a in term.args))
            except Exception as e:  # a user's cost function failed: say which term
                raise StreamFailure(f"function {term} raised {type(e).__name__}: {e}") from e
        out[term] = cache[term]
    return out


def compile_task(
    problem: Problem,
    facts: Iterable[Atom],
    optimistic: Iterable[OptInstance],
    costs: Mapping[FuncTerm, float],
    object_types: Mapping[str, str],
    negative_tests: set[str],
) -> Task:
    init = set(facts) | {a for i in optimistic for a in i.certified}
    objects = dict(object_types)
    for a in init:
        for t in a.args:
            objects.setdefault(t, "object")
    constants = {c.name for c in problem.domain.constants}
    obj_text = " ".join(
        o if t == "object" else f"{o} - {t}"
        for o, t in sorted(objects.items())
        if o not in constants
    )
    init_text = [str(a) for a in sorted(init)]
    init_text.append("(= (total-cost) 0)")  # compile_domain gives every action a cost
    init_text += [f"(= {t} {_scaled(v)})" for t, v in sorted(costs.items(), key=str)]
    goal = _rewrite(problem.goal, negative_tests)
    text = (
        f"(define (problem {problem.name})\n  (:domain {problem.domain.name})\n"
        f"  (:objects {obj_text})\n  (:init\n    " + "\n    ".join(init_text) + ")\n"
        f"  (:goal {goal})\n  (:metric minimize (total-cost)))\n"
    )
    return Task(text)


__all__ = [
    "COST_SCALE",
    "CompiledDomain",
    "Task",
    "compile_domain",
    "compile_task",
    "function_values",
]
