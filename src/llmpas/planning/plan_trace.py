"""From a classical plan over placeholders to the stream instances it relies on (:class:`Trace`,
:func:`retrace`) and to the final :class:`~llmpas.planning.result.Plan` (:func:`final_plan`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from llmpas.language.logic import Atom, Substitution
from llmpas.language.semantics import Semantics, preimage, replay
from llmpas.planning.compile import (
    COST_SCALE,
    compile_goal,
    external_facts,
)
from llmpas.planning.fluents import (
    context,
)
from llmpas.planning.instances import (
    OptInstance,
)
from llmpas.planning.planner_run import Run, object_types
from llmpas.planning.result import (
    Plan,
    PlanStep,
    StreamInstance,
)


class Trace:
    """Which optimistic instances a plan relies on, and which producer feeds each placeholder
    input. Placeholders may be shared by several instances (see :mod:`instances`); the producer
    of a placeholder is chosen from the facts its consumer needs: the instance most recently
    chosen that certifies them, else the cheapest lowest-level one that does."""

    def __init__(self, opt: list[OptInstance], real: set[Atom], fluent: Iterable[str] = ()) -> None:
        ordered = sorted(opt, key=lambda i: (i.level, i.stream.info.expected_cost))
        self.certifiers: dict[Atom, list[OptInstance]] = {}
        self.first: dict[str, OptInstance] = {}
        for i in ordered:
            for o in i.outputs:
                self.first.setdefault(o, i)
            for a in i.certified:
                if a not in real:
                    self.certifiers.setdefault(a, []).append(i)
        self.arg_sources: list[dict[str, OptInstance]] = []  # per step: argument -> producer
        self.wanted: set[Atom] = set()  # every fact the plan relies on
        self.chosen: list[OptInstance] = []  # in the order first needed
        self._chosen_ids: set[int] = set()
        self.sources: dict[int, dict[str, OptInstance]] = {}  # id(consumer) -> input -> producer
        # fluent streams: one copy of an instance per step that needs it (see :mod:`.fluents`)
        self.fluent = frozenset(fluent)
        self._k = 0
        self._copies: dict[tuple[int, int], OptInstance] = {}
        self._origin: dict[int, OptInstance] = {}
        self.actions: tuple[tuple[str, tuple[str, ...]], ...] = ()
        #: per step, the real facts of fluent streams it relies on, certified in its context
        self.in_context: list[dict[Atom, frozenset[Atom]]] = []
        #: id() of the tests read negated added to the stream plan (plan_tests.with_plan_tests)
        self.negated: set[int] = set()

    def step(self, k: int, facts: list[Atom], args: tuple[str, ...]) -> list[OptInstance]:
        """Instances newly needed for step ``k``'s (or the goal's) facts and arguments,
        producers first."""
        self._k = k
        out: list[OptInstance] = []
        for a in facts:
            if a in self.certifiers:
                self._need(self._certifier(a), out)
        sources: dict[str, OptInstance] = {}
        for x in args:
            if x in self.first:
                sources[x] = self._need(self._producer(x, facts), out)
        self.arg_sources.append(sources)
        return out

    def _certifier(self, fact: Atom) -> OptInstance:
        for c in reversed(self.chosen):
            if fact in c.certified:
                return c
        # the one certifying most of what the whole plan relies on (a placeholder's facts may be
        # needed at different steps); ties: the first (lowest level, cheapest)
        wanted = self.wanted
        return max(self.certifiers[fact], key=lambda c: len(wanted.intersection(c.certified)))

    def _producer(self, x: str, context: list[Atom]) -> OptInstance:
        """The instance standing behind placeholder ``x`` where ``context`` is needed."""
        mentioned = [a for a in context if x in a.args and a in self.certifiers]
        for a in mentioned:
            c = self._certifier(a)
            if x in c.outputs:
                return c
        for c in reversed(self.chosen):
            if x in c.outputs:
                return c
        return self.first[x]

    def _need(self, inst: OptInstance, out: list[OptInstance]) -> OptInstance:
        """Add ``inst`` (for a fluent stream: its copy for the current step) and its
        producers; the instance added."""
        if inst.stream.schema.name in self.fluent:
            inst = self._copy(inst)
        if id(inst) in self._chosen_ids:
            return inst
        self.chosen.append(inst)  # before its producers: guards against cycles
        self._chosen_ids.add(id(inst))
        sources: dict[str, OptInstance] = {}
        for x in inst.inputs:
            if x in self.first:
                sources[x] = self._need(self._producer(x, list(inst.domain)), out)
        self.sources[id(inst)] = sources
        out.append(inst)
        return inst

    def _copy(self, inst: OptInstance) -> OptInstance:
        origin = self._origin.get(id(inst), inst)
        key = (id(origin), self._k)
        if key not in self._copies:
            copy = dataclasses.replace(origin, step=self._k)
            self._copies[key] = copy
            self._origin[id(copy)] = origin
        return self._copies[key]


def retrace(
    run: Run, actions: tuple[tuple[str, tuple[str, ...]], ...], opt: list[OptInstance]
) -> tuple[list[list[OptInstance]], Trace] | None:
    """Per plan step (plus one last entry for the goal), the optimistic instances it relies on,
    producers first, each instance listed once (at its first use); None if the plan is not
    valid over the real and optimistic facts."""
    store = run.store
    trace = Trace(opt, store.facts, run.fluent)
    trace.actions = actions
    sem = Semantics(run.compiled.domain, object_types(run, opt), run.costs)
    init = store.facts | store.rejected | set(trace.certifiers) | store.fluent_facts.keys()
    support = preimage(sem, init, actions, compile_goal(run.problem, run.negative_tests))
    if support is None:
        return None
    states = replay(sem, init, actions).states if run.fluent else ()
    trace.wanted = set().union(*support)
    out: list[list[OptInstance]] = []
    by_predicate = run.fluent_by_predicate
    for k, facts in enumerate(support):
        args = actions[k][1] if k < len(actions) else ()
        here: dict[Atom, frozenset[Atom]] = {}
        for a in facts:
            name = by_predicate.get(a.predicate)
            if name is None or a not in store.fluent_facts:
                continue
            fluents = step_context(sem, states[k], run.fluent[name].schema.fluents)
            if store.holds_in(a, fluents):
                here[a] = fluents
            elif a not in trace.certifiers:
                return None  # a fluent stream's fact outside the context it was certified in
        trace.in_context.append(here)
        out.append(trace.step(k, sorted(facts - here.keys()), args))
    return out, trace


def step_context(sem: Semantics, facts: Iterable[Atom], fluents: Iterable[str]) -> frozenset[Atom]:
    """The facts of the ``fluents`` predicates in the state of base ``facts`` (derived ones
    computed when a fluent predicate is derived)."""
    preds = set(fluents)
    if preds & sem.domain.derived_names:
        return context(sem.closure(facts).facts, preds)
    return context(facts, preds)


def replayed(
    traced: tuple[list[list[OptInstance]], Trace] | None,
) -> tuple[list[list[OptInstance]], Trace]:
    if traced is None:
        raise RuntimeError("the classical plan does not replay under the domain semantics")
    return traced


def final_plan(
    run: Run,
    actions: tuple[tuple[str, tuple[str, ...]], ...],
    per_step: list[list[OptInstance]],
    classical_cost: float,
    trace: Trace,
) -> Plan:
    """The plan: deferred instances go to the step that first needs them (the goal's to the last
    step); inlined deferred streams get fresh placeholders for their outputs."""
    steps_insts = [list(x) for x in per_step[: len(actions)]]
    if steps_insts and len(per_step) > len(actions):
        steps_insts[-1] += per_step[-1]
    counter = iter(range(1, 1_000_000))
    steps: list[PlanStep] = []
    facts: dict[StreamInstance, tuple[Atom, ...]] = {}
    for (name, args), insts in zip(actions, steps_insts, strict=True):
        mine = [StreamInstance(i.stream.schema.name, i.inputs, i.outputs) for i in insts]
        facts.update({ref: i.certified for ref, i in zip(mine, insts, strict=True)})
        full, uses = run.compiled.expand(name, args, lambda: f"#d{next(counter)}")
        for use, env in uses:
            sub = Substitution(env)
            ref = StreamInstance(
                use.stream,
                tuple(sub.term(t) for t in use.inputs),
                tuple(sub.term(t) for t in use.outputs),
            )
            mine.append(ref)
            facts[ref] = tuple(sub.atom(a) for a in use.certified)
        steps.append(PlanStep(name, full, tuple(mine)))
    deferred = tuple(d for st in steps for d in st.deferred)
    certified = {a for a in run.store.facts if a not in run.problem.init}
    certified |= {a for d in deferred for a in facts[d]}
    certified |= external_facts(run.problem, run.store.rejected)
    in_context = {a for here in trace.in_context for a in here}
    certified |= in_context
    return Plan(
        steps=tuple(steps),
        cost=classical_cost / COST_SCALE,
        objects={**run.store.values, **{o: None for d in deferred for o in d.outputs}},
        certified=frozenset(certified),
        deferred=deferred,
        deferred_facts=facts,
        fluent_facts={a: frozenset(run.store.fluent_facts[a]) for a in in_context},
        reported=frozenset(run.store.wild - run.problem.init),
    )
