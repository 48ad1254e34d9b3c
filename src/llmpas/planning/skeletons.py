"""Evaluating an optimistic plan's streams and the skeleton queue (focused planning).

:func:`evaluate_streams` binds a stream plan in order with backtracking to upstream samplers;
an evaluated plan that does not hold is kept as a skeleton (:class:`Evaluated`) and drawn again
with growing effort (:func:`resample`); :func:`realize` turns an evaluated plan into a plan over
the real values when it still holds.
"""

from __future__ import annotations

import dataclasses
import logging
from collections import Counter
from dataclasses import dataclass

from llmpas.language.logic import Atom
from llmpas.language.semantics import Semantics, replay
from llmpas.planning.compile import (
    COST_SCALE,
)
from llmpas.planning.instances import (
    OptInstance,
    Record,
    evaluate_negative_tests,
    is_optimistic,
)
from llmpas.planning.plan_tests import check_plan_tests
from llmpas.planning.plan_trace import Trace, final_plan, retrace, step_context
from llmpas.planning.planner_run import Run, negative_streams, object_types, update_costs
from llmpas.planning.result import (
    Plan,
)

log = logging.getLogger(__name__)


def evaluate_streams(
    run: Run,
    needed: list[OptInstance],
    trace: Trace,
    effort: int = 1,
    kept: dict[int, dict[str, str]] | None = None,
) -> dict[int, dict[str, str]]:
    """Evaluate a stream plan in order; each placeholder input takes the real output of the
    producer the trace chose for it. Returns, per evaluated instance (by id), its placeholder
    outputs -> the real names.

    When an instance fails (a test rejects, a function finds nothing), the plan's skeleton is
    kept and the binding is searched further, as PDDLStream's adaptive algorithm does: the most
    recently evaluated sampler upstream of the failure draws a new value and only what depends
    on it is evaluated again, at most ``_RETRIES`` times per failed instance (``_NEGATED_RETRIES``
    for a test the plan reads negated, added by :func:`~llmpas.planning.plan_tests.with_plan_tests`:
    the latest sampler upstream draws again; taking the samplers upstream in turn measured
    worse). ``kept``: bindings of an earlier
    evaluation that stay (a skeleton drawn again goes on from its failed instances). For a fluent
    stream, the samplers of the values in its context (where the plan put things before) are
    upstream too, and each retry takes the next one back."""
    binder = _Binder(run, needed, trace)
    binder.real.update(kept or {})
    position, retries = 0, Counter[int]()
    while position < len(needed):
        limit = _retries(trace, needed[position]) * effort
        if binder.bind(position) or retries[position] >= limit:
            position += 1
        else:
            back = binder.backtrack(position, retries[position])
            if back is None:
                position += 1
            else:
                retries[position] += 1
                position = back
        if run.store.out_of_time():
            break
    return binder.real


_RETRIES = 2  # new values drawn upstream of one failed instance, per stream plan (effort 1)
#: the same for a test the plan reads negated (a collision test: a new sample usually passes)
_NEGATED_RETRIES = 6


def _retries(trace: Trace, inst: OptInstance) -> int:
    return _NEGATED_RETRIES if id(inst) in trace.negated else _RETRIES


class _Binder:
    """The bindings of one stream plan, with backtracking to upstream samplers."""

    def __init__(self, run: Run, needed: list[OptInstance], trace: Trace) -> None:
        self.run, self.needed, self.trace = run, needed, trace
        self.position = {id(inst): k for k, inst in enumerate(needed)}
        self.real: dict[int, dict[str, str]] = {}  # id(evaluated instance) -> placeholder -> real
        self.fresh: set[int] = set()  # instances to call for a new value (backtracked to)
        self.fluent_failed = False  # a fluent stream failed: the later ones are not evaluated
        self.contexts: dict[int, frozenset[Atom]] = {}  # id(fluent copy) -> its last context

    def _inputs(self, inst: OptInstance) -> tuple[str, ...]:
        sources = self.trace.sources.get(id(inst), {})
        real = self.real
        return tuple(
            real.get(id(sources[x]), {}).get(x, x) if x in sources else x for x in inst.inputs
        )

    def bind(self, k: int) -> bool:
        """Evaluate ``needed[k]`` unless it is bound already; whether it is bound now."""
        inst = self.needed[k]
        if id(inst) in self.real:
            return True
        inputs = self._inputs(inst)
        if any(is_optimistic(x) for x in inputs):
            return False  # a producer failed
        if inst.step is not None:
            return self._bind_fluent(inst, inputs)
        store = self.run.store
        rec = store.record(inst.stream, inputs)
        out = store.call(rec)
        rec.enabled = False
        log.debug("  %s(%s) -> %s", inst.stream.schema.name, " ".join(inputs), out)
        if out is None and rec.outputs and id(inst) not in self.fresh:
            out = rec.outputs[-1]  # called before on these inputs: its last output
        self.fresh.discard(id(inst))
        if out is None:
            return False
        self.real[id(inst)] = dict(zip(inst.outputs, out, strict=True))
        return True

    def _bind_fluent(self, inst: OptInstance, inputs: tuple[str, ...]) -> bool:
        """Evaluate a fluent stream's instance in the state before its step (the plan's real
        values up to there): an output it gave in that context before is used again; a
        failure blocks the instance in that context."""
        if self.fluent_failed:
            return False
        fluents = self._context_at(inst)
        if fluents is None:
            return False  # a step before it has no real values
        self.contexts[id(inst)] = fluents
        store = self.run.store
        rec = store.fluent_record(inst.stream, inputs, fluents)
        out = rec.outputs[-1] if rec.outputs else store.call(rec)
        log.debug(
            "  %s(%s) at step %s with %d fluent facts -> %s",
            inst.stream.schema.name, " ".join(inputs), inst.step, len(fluents), out,
        )  # fmt: skip
        if out is None:
            store.block(rec)
            self.fluent_failed = True
            return False
        self.real[id(inst)] = dict(zip(inst.outputs, out, strict=True))
        return True

    def _context_at(self, inst: OptInstance) -> frozenset[Atom] | None:
        """The fluent facts of ``inst``'s stream before its step, the steps before it applied
        with their real arguments (placeholders of deferred streams kept); None when one of
        those arguments has no real value."""
        run, trace = self.run, self.trace
        assert inst.step is not None
        sem = Semantics(
            run.compiled.domain,
            dict.fromkeys(run.store.values, "object") | dict(run.problem.object_types),
            run.costs,
            strict_costs=False,
        )
        facts = set(run.store.facts) | run.store.rejected
        for j in range(inst.step):
            name, args = trace.actions[j]
            sources = trace.arg_sources[j]
            real = []
            for x in args:
                src = sources.get(x)
                if src is None:
                    real.append(x)
                    continue
                got = self.real.get(id(src), {}).get(x)
                if got is None and not run.deferred(src.stream):
                    return None
                real.append(x if got is None else got)
            facts, _ = sem.apply(sem.domain.action(name), tuple(real), sem.state(facts))
        return step_context(sem, facts, inst.stream.schema.fluents)

    def backtrack(self, k: int, attempt: int = 0) -> int | None:
        """After ``needed[k]`` failed: the position of the latest sampler upstream of it that
        may give another value (for a fluent stream, the ``attempt``-th latest, round), with
        everything depending on that sampler unbound; None if there is none."""
        failed = self.needed[k]
        upstream = self._upstream(failed)
        candidates: list[tuple[int, Record]] = []
        for j in sorted((self.position[i] for i in upstream), reverse=True):
            inst = self.needed[j]
            rec = self.run.store.records.get((inst.stream.schema.name, self._inputs(inst)))
            if inst.outputs and rec is not None and not rec.exhausted:
                candidates.append((j, rec))
        if failed.step is not None and candidates:
            candidates = candidates[attempt % len(candidates) :][:1]
        for j, rec in candidates:
            inst = self.needed[j]
            if not self._worth_retrying(failed, inst, rec):
                return None
            for dependent in (*self._downstream(inst), id(inst)):
                self.real.pop(dependent, None)
            for later in self.needed:  # fluent contexts may change with the new value
                if later.step is not None:
                    self.real.pop(id(later), None)
            self.fluent_failed = False
            self.fresh.add(id(inst))
            return j
        return None

    def _worth_retrying(self, failed: OptInstance, sampler: OptInstance, rec: Record) -> bool:
        """Whether a new value of ``sampler`` may make the test ``failed`` pass: when the test
        takes one of its values directly, only if the same test passed on another of its
        values (otherwise the failure is taken as structural, e.g. a slot that another block
        fills, and left to the next search)."""
        if failed.outputs or id(failed) in self.trace.negated:
            return True  # a sampler found nothing, or a sample fails a test the plan reads negated
        sources = self.trace.sources.get(id(failed), {})
        inputs = self._inputs(failed)
        store = self.run.store
        for j, x in enumerate(failed.inputs):
            if sources.get(x) is not sampler:
                continue
            k = sampler.outputs.index(x)
            others = {out[k] for out in rec.outputs} - {inputs[j]}
            name = failed.stream.schema.name
            return any(
                (test := store.records.get((name, (*inputs[:j], o, *inputs[j + 1 :])))) is not None
                and bool(test.outputs)
                for o in others
            )
        return True

    def _upstream(self, inst: OptInstance) -> set[int]:
        """The instances of the stream plan whose values ``inst`` depends on: its producers,
        theirs, and so on; for a fluent stream also the producers of the values in its last
        context."""
        found: set[int] = set()
        todo = [inst]
        context = self.contexts.get(id(inst))
        if context is not None:
            named = {x for a in context for x in a.args}
            for other in self.needed:
                made = self.real.get(id(other), {}).values()
                if other.step is None and named.intersection(made):
                    found.add(id(other))
                    todo.append(other)
        while todo:
            for producer in self.trace.sources.get(id(todo.pop()), {}).values():
                if id(producer) in self.position and id(producer) not in found:
                    found.add(id(producer))
                    todo.append(producer)
        return found

    def _downstream(self, inst: OptInstance) -> set[int]:
        """What depends on ``inst``: one pass, since producers come first."""
        found = {id(inst)}
        for later in self.needed[self.position[id(inst)] + 1 :]:
            producers = self.trace.sources.get(id(later), {}).values()
            if any(id(p) in found for p in producers):
                found.add(id(later))
        return found - {id(inst)}


@dataclass(frozen=True)
class Evaluated:
    """A plan over placeholders whose stream plan was evaluated (``effort``: how many times;
    a skeleton of the queue is evaluated again with one more)."""

    actions: tuple[tuple[str, tuple[str, ...]], ...]
    instances: list[OptInstance]  # producers first
    trace: Trace
    real: dict[int, dict[str, str]]  # id(evaluated instance) -> placeholder -> real name
    needed: tuple[OptInstance, ...] = ()  # what was evaluated, in order
    effort: int = 1


MAX_SKELETONS = 4  # skeletons kept to draw again (the newest first)
_MAX_EFFORT = 4  # evaluations of one skeleton, the first included


def resamplable(done: Evaluated) -> bool:
    """Whether a plan that did not hold is kept as a skeleton: it needed streams and has effort
    left. Fluent instances are evaluated again in the contexts the new values give (the
    binding computes each one's context from the plan's steps before it)."""
    return bool(done.needed) and done.effort < _MAX_EFFORT


def resample(run: Run, skeletons: list[Evaluated], opt: list[OptInstance]) -> Plan | None:
    """Evaluate the oldest kept skeleton again, with more effort (more values drawn per
    failure): the plan over the new values if it holds (it leaves the queue), else None (it
    goes back to the end of the queue while it has effort left). A failed binding is so
    retried with new samples before the task is searched again, and the skeletons kept are
    drawn in turn, one per iteration, interleaved with the searches."""
    skeleton = skeletons.pop()
    effort = skeleton.effort + 1
    needed = list(skeleton.needed)
    # with tests read negated in its stream plan (#44): the values that were bound stay, and
    # the binding goes on from the instances that failed, as PDDLStream's bindings do
    kept = skeleton.real if skeleton.trace.negated else None
    real = evaluate_streams(run, needed, skeleton.trace, effort, kept)
    again = dataclasses.replace(skeleton, real=real, effort=effort)
    log.debug(
        "iteration %d: skeleton of %d steps drawn again (effort %d): %d of %d bound",
        run.iterations, len(skeleton.actions), effort, len(real), len(needed),
    )  # fmt: skip
    plan = None
    if len(real) == len(needed):
        # as before a search: the tests read negated, on the new values too
        evaluate_negative_tests(run.store, negative_streams(run))
        update_costs(run, opt)  # the new values' function values
        plan = realize(run, again, opt)
    if plan is None and resamplable(again):
        skeletons.insert(0, again)
    return plan


def realize(run: Run, done: Evaluated, opt: list[OptInstance]) -> Plan | None:
    """The evaluated plan with every placeholder replaced by the value its producer gave (and
    deferred placeholders by those of the same deferred instances on the real inputs), if it is
    still a plan over the real facts that needs no further evaluation; else None. Saves the
    search that would find it again, and stops the optimistic search from wandering to other
    plans once one plan's streams have all succeeded."""
    deferred = {i.key: i for i in opt if run.deferred(i.stream)}
    bound: dict[int, dict[str, str]] = {}
    for inst in done.instances:
        inputs = _bind(inst.inputs, done.trace.sources.get(id(inst), {}), bound)
        if inputs is None:
            return None
        if run.deferred(inst.stream):
            now = deferred.get((inst.stream.schema.name, inputs))
            if now is None:
                return None
            bound[id(inst)] = dict(zip(inst.outputs, now.outputs, strict=True))
        elif id(inst) in done.real:
            bound[id(inst)] = done.real[id(inst)]
        else:
            return None  # it failed, or was not reached
    actions = []
    for (name, args), sources in zip(done.actions, done.trace.arg_sources, strict=False):
        real_args = _bind(args, sources, bound)
        if real_args is None:
            return None
        actions.append((name, real_args))
    check_plan_tests(run, tuple(actions), opt)  # the tests it reads negated, then the check
    traced = retrace(run, tuple(actions), opt)
    if traced is None:
        return None
    per_step, trace = traced
    if any(not run.deferred(i.stream) for insts in per_step for i in insts):
        return None
    log.debug("iteration %d: the evaluated plan holds with the real values", run.iterations)
    cost = _plan_cost(run, tuple(actions), opt)
    return final_plan(run, tuple(actions), per_step, cost, trace)


def _bind(
    names: tuple[str, ...], sources: dict[str, OptInstance], bound: dict[int, dict[str, str]]
) -> tuple[str, ...] | None:
    out = [bound.get(id(sources[x]), {}).get(x) if x in sources else x for x in names]
    return None if None in out else tuple(o for o in out if o is not None)


def _plan_cost(
    run: Run, actions: tuple[tuple[str, tuple[str, ...]], ...], opt: list[OptInstance]
) -> float:
    """The plan's cost as Fast Downward would count it (scaled costs, compiled domain)."""
    scaled = {t: float(max(0, round(v * COST_SCALE))) for t, v in run.costs.items()}
    sem = Semantics(run.compiled.domain, object_types(run, opt), scaled)
    init = run.store.facts | run.store.rejected | {a for i in opt for a in i.certified}
    return replay(sem, init | run.store.fluent_facts.keys(), actions).cost
