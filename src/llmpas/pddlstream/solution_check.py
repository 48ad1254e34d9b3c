"""Checking a solution of ``solve`` by replay, with llmpas's PDDL semantics, independently of
the planner's bookkeeping.

The plan is replayed from the init and the facts its samplers certified (the streams'
contract: an output satisfies what the stream certifies), and those streams reported beyond it
(PDDLStream's ``WildOutput`` facts, taken on the same word). Everything else a plan may rely on is
recomputed here by calling the user's implementations again on the values: tests (``:stream``
without outputs) and external ``:predicate`` s on every instance of their domain among those
facts, rules likewise; costs by calling the ``:function`` s on the values each step uses. The
planner's own test results and costs are not used. The goal must hold at the end and the
replayed cost must equal the reported one.

Streams with ``:fluents`` are checked per step: a fact a fluent sampler certified holds only in
the states whose fluent facts are those it was certified with (the plan records them), and a
fluent test is called again with the fluent facts of each state it may matter in.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from llmpas.language.bindings import BoundStream
from llmpas.language.logic import Atom, Formula, FuncTerm
from llmpas.language.problem import Problem
from llmpas.language.semantics import Replay, Semantics, replay
from llmpas.pddlstream.solving import Attempt
from llmpas.planning.result import Plan

MAX_ROUNDS = 20  # rounds of recomputing tests and rules (each adds facts; a fixpoint is early)


@dataclass(frozen=True)
class Validation:
    """``valid`` with message "ok", or the first problem found."""

    valid: bool
    message: str
    cost: float = math.nan

    def __post_init__(self) -> None:
        if self.valid != (self.message == "ok"):
            raise ValueError("a valid solution has the message 'ok', an invalid one its reason")


def validate(attempt: Attempt) -> Validation:
    """Replay ``attempt``'s plan (module docstring)."""
    plan = attempt.result.plan
    if plan is None:
        return Validation(False, "no plan")
    problem = attempt.translation.problem
    values = {**problem.objects, **{k: v for k, v in plan.objects.items() if v is not None}}
    fluent = _fluent_streams(problem)
    used = _used(problem, plan)
    facts = set(problem.init) | _sampled(problem, plan, fluent, used) | plan.reported
    raised: list[str] = []
    facts |= recomputed(problem, facts, values, raised, skip=set(fluent))
    names = set(values) | {t for a in facts | plan.fluent_facts.keys() for t in a.args}
    costs = _Costs(problem, values)
    sem = Semantics(problem.domain, dict.fromkeys(names, "object"), costs)
    steps = [(s.action, s.args) for s in plan.steps]
    try:
        if fluent:
            result = _InContext(sem, fluent, plan, values, raised).replay(
                facts, steps, problem.goal
            )
        else:
            result = replay(sem, facts, steps, problem.goal)
    except Exception as e:  # a function that raises or answers no number
        return Validation(False, f"replay: {type(e).__name__}: {e}")
    if not result.valid:
        why = f" ({len(raised)} test call(s) raised, first: {raised[0]})" if raised else ""
        return Validation(False, f"replay: {result.message}{why}")
    cost = float(len(steps)) if attempt.unit_costs else result.cost
    if not math.isclose(cost, attempt.solution.cost, rel_tol=1e-3, abs_tol=1e-2):
        return Validation(
            False, f"replayed cost {cost:g} differs from the reported {attempt.solution.cost:g}"
        )
    return Validation(True, "ok", cost)


def _fluent_streams(problem: Problem) -> dict[str, BoundStream]:
    return {
        n: b
        for n, b in problem.bound_streams.items()
        if b.schema.fluents and b.schema.kind == "stream"
    }


def _used(problem: Problem, plan: Plan) -> set[str]:
    """The objects a replay of the plan can meet: the init's, the domain's constants and the
    plan's arguments (a state changes only through the plan's steps)."""
    used = set(problem.objects) | {c.name for c in problem.domain.constants}
    used |= {t for a in problem.init for t in a.args}
    return used | {t for s in plan.steps for t in s.args}


def _sampled(
    problem: Problem, plan: Plan, fluent: Mapping[str, BoundStream], used: set[str]
) -> set[Atom]:
    """The plan's certified facts of predicates that a stream with outputs and without
    ``:fluents`` certifies, on the objects the plan uses (``used``): the samples it does not
    use (drawn and rejected while planning) are left out, so that the tests recomputed on
    every binding of them (quadratic in the samples) are not; leaving facts out can only make
    the replay stricter."""
    sampled = {
        a.predicate
        for s in problem.streams.streams
        if s.outputs and s.name not in fluent
        for a in s.certified
    }
    return {a for a in plan.certified if a.predicate in sampled and used.issuperset(a.args)}


class _InContext:
    """A replay in which the facts of fluent streams hold only where their context does."""

    def __init__(
        self,
        sem: Semantics,
        fluent: Mapping[str, BoundStream],
        plan: Plan,
        values: Mapping[str, Any],
        raised: list[str],
    ) -> None:
        self.sem, self.fluent, self.plan, self.values, self.raised = (
            sem,
            fluent,
            plan,
            values,
            raised,
        )
        self.tests: dict[tuple[str, tuple[str, ...], frozenset[Atom]], bool] = {}

    def _context(self, base: set[Atom], b: BoundStream) -> frozenset[Atom]:
        preds = set(b.schema.fluents)
        facts = self.sem.closure(base).facts if preds & self.sem.domain.derived_names else base
        return frozenset(a for a in facts if a.predicate in preds)

    def facts(self, base: set[Atom]) -> set[Atom]:
        """The fluent streams' facts that hold in the state of ``base`` facts."""
        out: set[Atom] = set()
        for b in (self.fluent[n] for n in sorted(self.fluent)):
            ctx = self._context(base, b)
            preds = {a.predicate for a in b.schema.certified}
            if b.schema.outputs:
                out |= {
                    a
                    for a, contexts in self.plan.fluent_facts.items()
                    if a.predicate in preds and ctx in contexts
                }
                continue
            for env in _bindings(b.schema.domain, base | out):
                args = tuple(env[v] for v in b.schema.inputs)
                if self._test(b, args, ctx):
                    out |= {
                        Atom(a.predicate, tuple(env.get(t, t) for t in a.args))
                        for a in b.schema.certified
                    }
        return out

    def _test(self, b: BoundStream, args: tuple[str, ...], ctx: frozenset[Atom]) -> bool:
        key = (b.schema.name, args, ctx)
        if key not in self.tests:
            fluents = b.fluent_arguments(ctx, self.values)
            inputs = tuple(self.values.get(a, a) for a in args)
            try:
                self.tests[key] = next(iter(b.outputs(inputs, fluents)), None) is not None
            except Exception as e:  # the user's code, on an instance it may not expect
                self.raised.append(f"{b.schema.name}({' '.join(args)}): {type(e).__name__}: {e}")
                self.tests[key] = False
        return self.tests[key]

    def replay(
        self, init: set[Atom], steps: list[tuple[str, tuple[str, ...]]], goal: Formula
    ) -> Replay:
        """The plan replayed with the stream facts recomputed in every state."""
        return replay(self.sem, init, steps, goal, implied=self.facts)


def recomputed(
    problem: Problem,
    facts: set[Atom],
    values: Mapping[str, Any],
    raised: list[str],
    skip: set[str] | None = None,
) -> set[Atom]:
    """Facts of tests, external predicates and rules, computed on ``values`` until nothing
    new holds (at most :data:`MAX_ROUNDS` rounds). A call that raises certifies nothing (the
    planner may never have needed that instance); ``raised`` gets what it raised."""
    out: set[Atom] = set()
    done: set[tuple[str, tuple[str, ...]]] = set()
    tests = [
        b
        for b in problem.bound_streams.values()
        if not b.schema.outputs and b.schema.name not in (skip or set())
    ]
    for _ in range(MAX_ROUNDS):
        known = facts | out
        new: set[Atom] = set()
        for bound in tests:
            s = bound.schema
            for env in _bindings(s.domain, known):
                args = tuple(env[v] for v in s.inputs)
                if (s.name, args) in done:
                    continue
                done.add((s.name, args))
                try:
                    holds = _holds(bound, args, values)
                except Exception as e:  # the user's code, on an instance it may not expect
                    raised.append(f"{s.name}({' '.join(args)}): {type(e).__name__}: {e}")
                    continue
                if s.is_predicate:  # the implementation says P; its test certifies not P
                    if not holds:
                        new.add(Atom(s.name, args))
                elif holds:
                    new |= {
                        Atom(a.predicate, tuple(env.get(t, t) for t in a.args)) for a in s.certified
                    }
        if not new - known:
            break
        out |= new
    return {a for a in out if not a.predicate.startswith("not__")}


def _holds(bound: BoundStream, args: tuple[str, ...], values: Mapping[str, Any]) -> bool:
    return next(iter(bound.outputs(tuple(values.get(a, a) for a in args))), None) is not None


def _bindings(domain: tuple[Atom, ...], facts: set[Atom]) -> Iterator[dict[str, str]]:
    """Every assignment of the variables of ``domain`` under which all its atoms are facts."""
    index: dict[str, list[Atom]] = {}
    for f in facts:
        index.setdefault(f.predicate, []).append(f)

    def extend(i: int, env: dict[str, str]) -> Iterator[dict[str, str]]:
        if i == len(domain):
            yield dict(env)
            return
        pattern = domain[i]
        for f in index.get(pattern.predicate, ()):
            if len(f.args) != len(pattern.args):
                continue
            new = dict(env)
            ok = True
            for p, v in zip(pattern.args, f.args, strict=True):
                if p.startswith("?"):
                    if new.setdefault(p, v) != v:
                        ok = False
                        break
                elif p != v:
                    ok = False
                    break
            if ok:
                yield from extend(i + 1, new)

    yield from extend(0, {})


class _Costs(Mapping[FuncTerm, float]):
    """Function values on demand: the init's, or the ``:function``'s implementation called on
    the values."""

    def __init__(self, problem: Problem, values: Mapping[str, Any]) -> None:
        self.problem = problem
        self.named = values
        self.cache: dict[FuncTerm, float] = {}

    def __getitem__(self, term: FuncTerm) -> float:
        if term in self.problem.costs:
            return self.problem.costs[term]
        if term not in self.cache:
            bound = self.problem.bound_functions.get(term.name)
            if bound is None:
                raise KeyError(term)
            self.cache[term] = bound.value(tuple(self.named.get(a, a) for a in term.args))
        return self.cache[term]

    def __contains__(self, term: object) -> bool:
        if not isinstance(term, FuncTerm):
            return False
        return term in self.problem.costs or term.name in self.problem.bound_functions

    def __iter__(self) -> Iterator[FuncTerm]:
        return iter({**self.problem.costs, **self.cache})

    def __len__(self) -> int:
        return len({**self.problem.costs, **self.cache})
