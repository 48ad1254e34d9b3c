"""Compile a TAMP problem state into a classical PDDL task for Fast Downward.

Real facts go to ``:init``. Each stream becomes a *stream action* ``stream__NAME`` whose
precondition is its ``:domain`` plus an ``inst__NAME`` fact naming one allowed instance (inputs and
placeholder outputs), and whose effect is its ``:certified`` facts, at the stream's overhead cost.
The plan then says exactly which unevaluated stream instances it relies on.

Negated atoms of test streams are rewritten to ``rejected__P`` facts: true only for bindings a test
has rejected (before a test is evaluated it is optimistically assumed to pass).
Fast Downward wants integer costs: every cost is multiplied by ``COST_SCALE`` and rounded.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

from llmpas.language.bindings import BoundFunction
from llmpas.language.domain import Action, Domain, Signature
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
    effort_function,
    inst_predicate,
    is_optimistic,
    join,
    rejected_predicate,
)

COST_SCALE = 100
STREAM_ACTION_PREFIX = "stream__"


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
    """The domain plus stream actions; the same for every iteration of a planning run."""
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
    preds: list[Signature] = []
    certified = problem.streams.certified_predicates
    for name, arity in certified.items():
        preds.append(Signature(name, tuple(Param(f"?x{i}") for i in range(arity))))
    for p in sorted(negative_tests):
        preds.append(Signature(rejected_predicate(p), _vars(certified[p])))
    stream_actions = []
    for b in problem.bound_streams.values():
        s = b.schema
        params = s.inputs + s.outputs
        preds.append(Signature(inst_predicate(s.name), tuple(Param(v) for v in params)))
        pre = And((Atom(inst_predicate(s.name), params), *s.domain))
        effs: tuple[EffectItem, ...] = (
            *s.certified,
            Increase(FuncTerm(effort_function(s.name), params)),
        )
        stream_actions.append(
            Action(STREAM_ACTION_PREFIX + s.name, tuple(Param(v) for v in params), pre, effs)
        )
    functions = dict(d.functions)
    for b in problem.bound_streams.values():
        name = effort_function(b.schema.name)
        functions[name] = Signature(name, _vars(len(b.schema.inputs) + len(b.schema.outputs)))
    out = replace(
        d, actions=actions, derived=derived, undeclared={}, functions=functions
    ).with_additions(predicates=preds, actions=stream_actions)
    return CompiledDomain(out, out.to_pddl())


def _vars(n: int) -> tuple[Param, ...]:
    return tuple(Param(f"?x{i}") for i in range(n))


@dataclass(frozen=True)
class Task:
    """One classical task: the problem text and how to read the plan back."""

    problem_text: str
    optimistic: Mapping[tuple[str, tuple[str, ...]], OptInstance]  # (stream, inputs+outputs)


def function_values(
    problem: Problem,
    facts: Iterable[Atom],
    cache: dict[FuncTerm, float],
    optimistic_cost: float = 1.0,
) -> dict[FuncTerm, float]:
    """Values of every ``:function`` on the bindings its domain allows, plus the problem's costs."""
    out = dict(problem.costs)
    state = State(facts)
    for f in problem.bound_functions.values():
        out.update(_function_values(f, state, problem, cache, optimistic_cost))
    return out


def _function_values(
    f: BoundFunction, state: State, problem: Problem, cache: dict[FuncTerm, float], default: float
) -> dict[FuncTerm, float]:
    out: dict[FuncTerm, float] = {}
    head = f.schema.head
    for env in join(f.schema.domain, state):
        term = FuncTerm(head.predicate, Substitution(env).atom(head).args)
        if any(is_optimistic(a) for a in term.args):
            out[term] = default
            continue
        if term not in cache:
            cache[term] = f.value(tuple(problem.value(a) for a in term.args))
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
    opt = list(optimistic)
    init = set(facts) | {i.inst_atom for i in opt}
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
    init_text += [f"(= {i.effort_term} {_scaled(i.effort)})" for i in opt]
    goal = _rewrite(problem.goal, negative_tests)
    text = (
        f"(define (problem {problem.name})\n  (:domain {problem.domain.name})\n"
        f"  (:objects {obj_text})\n  (:init\n    " + "\n    ".join(init_text) + ")\n"
        f"  (:goal {goal})\n  (:metric minimize (total-cost)))\n"
    )
    return Task(text, {(i.stream.schema.name, i.inputs + i.outputs): i for i in opt})


__all__ = [
    "COST_SCALE",
    "STREAM_ACTION_PREFIX",
    "CompiledDomain",
    "Task",
    "compile_domain",
    "compile_task",
    "function_values",
]
