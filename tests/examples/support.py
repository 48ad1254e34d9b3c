"""Assembling plans by hand from stream calls, and replaying them against the domain."""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

from llmpas.language.logic import Atom, FuncTerm, is_var
from llmpas.language.problem import Problem
from llmpas.language.semantics import Replay, Semantics, replay


def _key(value: Any) -> Any:
    try:
        hash(value)
    except TypeError:
        return ("id", id(value))
    return ("h", type(value), value)


class HandPlan:
    """Names stream outputs, collects the facts streams certify, and records plan steps."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.values: dict[str, Any] = dict(problem.objects)
        self.names: dict[Any, str] = {_key(v): n for n, v in problem.objects.items()}
        self.facts: set[Atom] = set(problem.init)
        self.steps: list[tuple[str, tuple[str, ...]]] = []

    def name(self, value: Any) -> str:
        if isinstance(value, str):
            return value.lower()
        k = _key(value)
        if k not in self.names:
            n = f"h{len(self.names)}"
            self.names[k] = n
            self.values[n] = value
        return self.names[k]

    def call(self, stream: str, *inputs: Any) -> tuple[Any, ...] | None:
        """The first output of ``stream`` on ``inputs``; its certified facts are recorded."""
        bound = self.problem.bound_streams[stream]
        out = next(iter(bound.outputs(tuple(inputs))), None)
        if out is not None:
            self.certify(stream, inputs, out)
        return out

    def certify(self, stream: str, inputs: tuple[Any, ...], outputs: tuple[Any, ...]) -> None:
        schema = self.problem.bound_streams[stream].schema
        env = {
            v: self.name(x)
            for v, x in zip(schema.inputs + schema.outputs, inputs + outputs, strict=True)
        }
        self.facts |= {
            Atom(a.predicate, tuple(env.get(t, t) for t in a.args)) for a in schema.certified
        }

    def adopt(self, objects: Mapping[str, Any], certified: Iterable[Atom]) -> None:
        """Take over the objects and certified facts of a planner's plan."""
        for n, v in objects.items():
            self.values.setdefault(n, v)
            if v is not None:
                self.names.setdefault(_key(v), n)
        self.facts |= set(certified)

    def step(self, action: str, *args: Any) -> None:
        self.steps.append((action, tuple(self.name(a) for a in args)))

    def run_tests(self, stream: str) -> None:
        """Evaluate test ``stream`` on every binding of its domain in the facts so far (the
        replay reads an absent certified fact as a rejection)."""
        bound = self.problem.bound_streams[stream]
        for env in bindings(bound.schema.domain, self.facts):
            values = tuple(self.values.get(env[v]) for v in bound.schema.inputs)
            if any(v is None for v in values):
                continue  # a placeholder of a deferred stream: its value is not known yet
            if next(iter(bound.outputs(values)), None) is not None:
                self.certify(stream, values, ())

    def costs(self, default: float = 1.0) -> dict[FuncTerm, float]:
        """Every function on every pair its domain allows (``default`` for unknown values)."""
        out: dict[FuncTerm, float] = dict(self.problem.costs)
        for f in self.problem.bound_functions.values():
            for env in bindings(f.schema.domain, self.facts):
                args = tuple(env.get(t, t) for t in f.schema.head.args)
                values = tuple(self.values.get(a) for a in args)
                value = default if any(v is None for v in values) else f.value(values)
                out[FuncTerm(f.schema.head.predicate, args)] = value
        return out

    def replay(self) -> Replay:
        return replay_plan(self.problem, self.facts, self.steps, self.values, self.costs())


def bindings(atoms: tuple[Atom, ...], facts: set[Atom]) -> Iterator[dict[str, str]]:
    """Every assignment of the variables of the conjunction ``atoms`` that ``facts`` support."""
    by_pred: dict[str, list[Atom]] = {}
    for f in facts:
        by_pred.setdefault(f.predicate, []).append(f)
    options = [by_pred.get(a.predicate, []) for a in atoms]
    for combo in itertools.product(*options):
        env: dict[str, str] = {}
        if all(_unify(a, f, env) for a, f in zip(atoms, combo, strict=True)):
            yield env


def _unify(pattern: Atom, fact: Atom, env: dict[str, str]) -> bool:
    for t, v in zip(pattern.args, fact.args, strict=True):
        if is_var(t):
            if env.setdefault(t, v) != v:
                return False
        elif t != v:
            return False
    return True


def replay_plan(
    problem: Problem,
    facts: set[Atom] | frozenset[Atom],
    steps: list[tuple[str, tuple[str, ...]]],
    values: Mapping[str, Any],
    costs: Mapping[FuncTerm, float],
) -> Replay:
    names = set(values) | {t for a in facts for t in a.args}
    sem = Semantics(problem.domain, dict.fromkeys(names, "object"), costs)
    return replay(sem, facts, steps, problem.goal)
