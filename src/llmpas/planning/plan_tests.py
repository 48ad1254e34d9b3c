"""The tests a plan reads negated, evaluated for that plan only (focused planning, #44).

A test stream whose certified predicate occurs negated (``(not (CFreePosePose ...))`` in an
``UnsafePose`` axiom, say) is assumed to pass until evaluated: the compiled domain reads its
rejections (``rejected__P``). Rather than evaluating it on every real binding before each
search, as before, the tests are evaluated for the bindings a plan over real values relies
on: its *negative preimage*, as PDDLStream's focused algorithm does. For each step (and the
goal), each derived atom the step needs false (``(not (UnsafePose o p))``) is expanded through
its rules in a *hypothetical* state where every binding of a lazy test on which the test could
run (its ``:domain`` holds) counts as rejected; the rejections met in those witnesses are the
test instances the step relies on. They are evaluated (each once per run: the store keeps its
records, so results are reused by later plans and skeletons) until no instance the plan reads
is left unevaluated; a rejection changes the real facts and the caller checks the plan again.

What is not handled here (a ``forall`` over a negated derived atom, a test certifying more
than one atom, recursive axioms, conditional effects) makes the run fall back to evaluating
those tests on every real binding (:func:`check_plan_tests` returns after doing so).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable

from llmpas.language.bindings import BoundStream
from llmpas.language.domain import Derived, Param, Signature
from llmpas.language.logic import (
    And,
    Atom,
    Exists,
    Forall,
    Formula,
    Not,
    Or,
    Substitution,
    When,
    is_var,
)
from llmpas.language.semantics import Evaluator, Semantics, State, nnf
from llmpas.planning.compile import compile_goal
from llmpas.planning.instances import (
    OptInstance,
    evaluate_negative_tests,
    is_optimistic,
    rejected_predicate,
)
from llmpas.planning.plan_trace import Trace
from llmpas.planning.planner_run import Run, negative_streams, object_types

log = logging.getLogger(__name__)

Actions = tuple[tuple[str, tuple[str, ...]], ...]


class _Unsupported(Exception):
    """A formula shape the negative preimage does not cover."""


def lazy_tests(run: Run) -> frozenset[str]:
    """The test streams evaluated for a plan's bindings only: non-deferred tests read negated,
    neither eager nor ``p_success=0``, without ``:fluents``, certifying one atom over distinct
    variables that name every input, the only stream certifying that predicate; empty when the
    domain has conditional effects or recursive axioms."""
    domain = run.compiled.domain
    if any(_conditional(a.effects) for a in domain.actions) or not _rules_ok(run):
        return frozenset()
    by_predicate: dict[str, int] = {}
    for b in run.problem.bound_streams.values():
        for a in b.schema.certified:
            by_predicate[a.predicate] = by_predicate.get(a.predicate, 0) + 1
    read = _polarities(run)
    out = set()
    for b in run.problem.bound_streams.values():
        s = b.schema
        if not s.is_test or s.is_rule or s.fluents or run.deferred(b):
            continue
        if b.info.never_assumed or b.info.eager or len(s.certified) != 1:
            continue
        (c,) = s.certified
        if c.predicate not in run.negative_tests or by_predicate[c.predicate] != 1:
            continue
        if len(set(c.args)) != len(c.args) or not all(is_var(t) for t in c.args):
            continue
        if set(s.inputs) - set(c.args) or True in read.get(rejected_predicate(c.predicate), ()):
            continue  # a rejection a plan needs (not only one it needs absent): on every binding
        out.add(s.name)
    return frozenset(out)


def unread_tests(run: Run) -> frozenset[str]:
    """The lazy tests whose certified predicate no formula reads positively: their optimistic
    instances would add facts nothing reads."""
    read = _polarities(run)
    return frozenset(
        n
        for n in run.lazy
        if True not in read.get(run.problem.bound_streams[n].schema.certified[0].predicate, ())
    )


def _polarities(run: Run) -> dict[str, set[bool]]:
    """Per predicate, whether plans need its atoms true (True) or false (False), through the
    derived predicates: a rejection needed only absent is what a test assumed to pass gives."""
    domain = run.compiled.domain
    needed: list[tuple[bool, Formula]] = [(True, nnf(a.precondition)) for a in domain.actions]
    needed.append((True, nnf(compile_goal(run.problem, run.negative_tests))))
    bodies: dict[str, list[Formula]] = {}
    for d in domain.derived:
        bodies.setdefault(d.head.name, []).append(nnf(d.body))
    read: dict[str, set[bool]] = {}
    while needed:
        polarity, f = needed.pop()
        for positive, a in _signed_atoms(f):
            p = positive == polarity
            if p in read.setdefault(a.predicate, set()):
                continue
            read[a.predicate].add(p)
            needed += [(p, body) for body in bodies.get(a.predicate, ())]
    return read


def _signed_atoms(f: Formula) -> Iterable[tuple[bool, Atom]]:
    """The atoms of a formula in negation normal form, True where they occur positively (both
    under a ``forall``, conservatively)."""
    match f:
        case Atom():
            yield True, f
        case Not(Atom() as a):
            yield False, a
        case And(parts) | Or(parts):
            for part in parts:
                yield from _signed_atoms(part)
        case Exists(_, body):
            yield from _signed_atoms(body)
        case Forall(_, body):
            for _, a in _signed_atoms(body):
                yield True, a
                yield False, a


def _conditional(effects: Iterable[object]) -> bool:
    return any(isinstance(e, When) for e in effects)


def _rules_ok(run: Run) -> bool:
    sem = Semantics(run.compiled.domain, {})
    return bool(sem._rules) or not run.compiled.domain.derived


def _hypothetical_rules(run: Run) -> dict[str, list[Derived]]:
    """``rejected__P(args)`` :- the test's ``:domain``: every binding it could reject."""
    rules: dict[str, list[Derived]] = {}
    for name in run.lazy:
        s = run.problem.bound_streams[name].schema
        (c,) = s.certified
        head = tuple(f"?x{i}" for i in range(len(c.args)))
        sub = Substitution(dict(zip(c.args, head, strict=True)))
        body = And(tuple(sub.atom(a) for a in s.domain))
        pred = rejected_predicate(c.predicate)
        rules[pred] = [Derived(Signature(pred, tuple(Param(h) for h in head)), body)]
    return rules


class _Collector:
    """The lazy tests' rejections that one state's formulas rely on being absent."""

    def __init__(self, sem: Semantics, state: State, hyp: dict[str, list[Derived]]) -> None:
        self.real = sem.evaluator(state)
        self.derived = sem._rules
        self.hyp = Evaluator(sem.universe, state, {**sem._rules, **hyp})
        self.lazy = set(hyp)
        self.out: set[Atom] = set()
        self._false: set[Atom] = set()
        self._true: set[Atom] = set()

    def needs(self, f: Formula, env: dict[str, str]) -> None:
        """``f`` holds under ``env`` (real semantics): what its witness reads negated."""
        match f:
            case Atom() if f.predicate in self.derived:
                ground = self._ground(f, env)
                if ground in self._true:
                    return
                self._true.add(ground)
                for rule in self.derived[f.predicate]:
                    head = dict(zip((p.name for p in rule.head.params), ground.args, strict=True))
                    e = next(self.real.solve(rule.body, head, {}), None)
                    if e is not None:
                        self.needs(rule.body, e)
                        return
            case Not(Atom() as a) if a.predicate in self.derived:
                self.false(self._ground(a, env))
            case And(parts):
                for p in parts:
                    self.needs(p, env)
            case Or(parts):
                for p in parts:
                    e = next(self.real.solve(p, dict(env), {}), None)
                    if e is not None:
                        self.needs(p, e)
                        return
            case Exists(ps, body):
                inner = {k: v for k, v in env.items() if k not in {p.name for p in ps}}
                e = next(self.real.solve(body, inner, {}), None)
                if e is not None:
                    self.needs(body, e)
            case Forall():
                raise _Unsupported("forall")

    def false(self, ground: Atom) -> None:
        """The derived atom ``ground`` must be false: every rejection in any of its witnesses
        in the hypothetical state."""
        if ground in self._false:
            return
        self._false.add(ground)
        for rule in self.derived[ground.predicate]:
            head = dict(zip((p.name for p in rule.head.params), ground.args, strict=True))
            self._witness(rule.body, head)

    def _witness(self, f: Formula, env: dict[str, str]) -> None:
        match f:
            case Atom():
                if f.predicate not in self.lazy and f.predicate not in self.derived:
                    return
                for e in self.hyp.solve(f, dict(env), {}):
                    ground = self._ground(f, e)
                    if f.predicate in self.lazy:
                        self.out.add(ground)
                    else:
                        self.false(ground)
            case Not():
                return
            case And(parts):
                for e in self.hyp.solve(f, dict(env), {}):
                    for p in parts:
                        self._witness(p, e)
            case Or(parts):
                for p in parts:
                    self._witness(p, env)
            case Exists(ps, body):
                self._witness(body, {k: v for k, v in env.items() if k not in {p.name for p in ps}})
            case Forall():
                raise _Unsupported("forall")

    @staticmethod
    def _ground(a: Atom, env: dict[str, str]) -> Atom:
        args = tuple(env.get(t, t) for t in a.args)
        if any(is_var(t) for t in args):
            raise _Unsupported(f"unbound {a}")
        return Atom(a.predicate, args)


def plan_tests(run: Run, actions: Actions, init: set[Atom], opt: list[OptInstance]) -> set[Atom]:
    """The rejections of lazy tests the plan ``actions`` relies on being absent, per its
    steps' states from ``init`` (see the module's documentation)."""
    sem = Semantics(run.compiled.domain, object_types(run, opt), run.costs, strict_costs=False)
    hyp = _hypothetical_rules(run)
    state = sem.state(init)
    out: set[Atom] = set()
    for name, args in actions:
        action = sem.domain.action(name)
        env = sem._env(action, args)
        if not sem.evaluator(state).holds(action.precondition, env):
            return out  # not a plan over these facts: the caller's check says so
        c = _Collector(sem, state, hyp)
        c.needs(action.precondition, env)
        out |= c.out
        state = sem.successor(action, args, state)
    c = _Collector(sem, state, hyp)
    c.needs(compile_goal(run.problem, run.negative_tests), {})
    return out | c.out


def check_plan_tests(run: Run, actions: Actions, opt: list[OptInstance]) -> bool:
    """Evaluate the lazy tests ``actions`` reads negated, until none it relies on is left
    unevaluated; True when one of them rejected (the plan may not hold: check it again)."""
    if not run.lazy:
        return False
    store = run.store
    optimistic = {a for i in opt for a in i.certified}
    rejected = False
    while True:
        init = store.facts | store.rejected | optimistic | store.fluent_facts.keys()
        try:
            wanted = plan_tests(run, actions, init, opt)
        except _Unsupported as e:
            log.info("negated tests on every binding from now on: %s", e)
            run.lazy = run.unread = frozenset()
            before = len(store.rejected)
            evaluate_negative_tests(store, negative_streams(run))
            return rejected or len(store.rejected) > before
        todo = []
        for a in sorted(wanted, key=lambda a: (a.predicate, a.args)):
            bound, inputs = _test_of(run, a)
            if any(is_optimistic(x) for x in inputs):
                continue
            rec = store.record(bound, inputs)
            if rec.calls == 0 and not rec.exhausted:
                todo.append(rec)
        if not todo:
            return rejected
        for rec in todo:
            store.call(rec)
            if not rec.outputs:
                rejected = True
            if store.out_of_time():
                return True


def with_plan_tests(
    run: Run, actions: Actions, opt: list[OptInstance], trace: Trace, needed: list[OptInstance]
) -> list[OptInstance]:
    """The stream plan ``needed`` of an optimistic plan with the lazy tests it reads negated
    (its negative preimage over placeholders and real values) not evaluated yet, each right
    after the producers of its inputs: bound with the plan's values, so that a sample that
    fails one is drawn again in the binding (:func:`~llmpas.planning.skeletons.evaluate_streams`)
    rather than after another search, as in PDDLStream's stream plans."""
    if not run.lazy:
        return needed
    store = run.store
    init = store.facts | store.rejected | set(trace.certifiers) | store.fluent_facts.keys()
    try:
        wanted = plan_tests(run, actions, init, opt)
    except _Unsupported:
        return needed
    out = list(needed)
    for a in sorted(wanted, key=lambda a: (a.predicate, a.args)):
        bound, inputs = _test_of(run, a)
        rec = store.records.get((bound.schema.name, inputs))
        if rec is not None and (rec.calls or rec.exhausted):
            continue  # evaluated before: the plan's check reads its result
        inst = OptInstance(bound, inputs, (), (Atom(a.predicate[len(_REJECTED) :], a.args),), 0)
        added: list[OptInstance] = []
        trace._need(inst, added)
        if added != [inst]:  # it needs a producer the plan does not: left to the plan's check
            continue
        producers = {id(p) for p in trace.sources.get(id(inst), {}).values()}
        after = max((k for k, i in enumerate(out) if id(i) in producers), default=-1)
        out.insert(after + 1, inst)
        trace.negated.add(id(inst))
    return out


_REJECTED = rejected_predicate("")


def _test_of(run: Run, rejection: Atom) -> tuple[BoundStream, tuple[str, ...]]:
    """The lazy test instance whose rejection is ``rejection``."""
    predicate = rejection.predicate[len(_REJECTED) :]
    for name in sorted(run.lazy):
        bound = run.problem.bound_streams[name]
        (c,) = bound.schema.certified
        if c.predicate == predicate:
            position = {v: k for k, v in enumerate(c.args)}
            return bound, tuple(rejection.args[position[v]] for v in bound.schema.inputs)
    raise KeyError(rejection)
