"""Stream-based TAMP planning on a classical planner: ``focused`` and ``incremental``.

``focused`` (optimistic, in PDDLStream's terms *focused/adaptive*): stream outputs are placeholder
objects; the classical planner chooses which stream instances the plan relies on (stream actions,
see :mod:`llmpas.planning.compile`); only those are evaluated, in plan order; repeat until a plan
needs no unevaluated stream. An instance stays available until it is exhausted, but each call makes
its stream action dearer, so the search prefers real outputs and untried instances; no
intermediate search has to prove a task unsolvable.

``incremental``: evaluate every stream instance once per level on the real facts, then search.

In both, *deferred* streams are never evaluated here: the plan keeps their placeholders and lists,
per action, the deferred instances the executor must satisfy.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

from llmpas.language.bindings import BoundStream
from llmpas.language.logic import Atom, FuncTerm
from llmpas.language.problem import Problem
from llmpas.language.semantics import State
from llmpas.planning.compile import (
    COST_SCALE,
    STREAM_ACTION_PREFIX,
    CompiledDomain,
    compile_domain,
    compile_task,
    function_values,
)
from llmpas.planning.config import PlannerConfig
from llmpas.planning.downward import (
    ClassicalPlan,
    ClassicalPlanner,
    ClassicalStatus,
    DownwardConfig,
    FastDownward,
    PlannerNotFound,
)
from llmpas.planning.instances import (
    OptInstance,
    StreamFailure,
    StreamStore,
    evaluate_negative_tests,
    is_optimistic,
    join,
    negative_test_predicates,
    optimistic_instances,
)
from llmpas.planning.result import (
    Plan,
    PlanResult,
    PlanStats,
    PlanStatus,
    PlanStep,
    StreamInstance,
)

log = logging.getLogger(__name__)


@dataclass
class _Run:
    """Mutable bookkeeping of one call to :func:`solve`."""

    problem: Problem
    config: PlannerConfig
    classical: ClassicalPlanner
    store: StreamStore
    compiled: CompiledDomain
    negative_tests: set[str]
    started: float
    iterations: int = 0
    translate_time: float = 0.0
    search_time: float = 0.0
    cost_cache: dict[FuncTerm, float] = field(default_factory=dict)

    def deferred(self, b: BoundStream) -> bool:
        return self.config.defer and b.info.deferred

    def remaining(self) -> float:
        return self.config.max_time - (time.perf_counter() - self.started)

    def stats(self) -> PlanStats:
        return PlanStats(
            algorithm=self.config.algorithm,
            iterations=self.iterations,
            stream_calls=dict(self.store.calls),
            stream_time=self.store.time,
            translate_time=self.translate_time,
            search_time=self.search_time,
            total_time=time.perf_counter() - self.started,
        )

    def result(self, status: PlanStatus, message: str, plan: Plan | None = None) -> PlanResult:
        return PlanResult(status, plan, self.stats(), message)


def solve(
    problem: Problem,
    config: PlannerConfig | None = None,
    classical: ClassicalPlanner | None = None,
) -> PlanResult:
    """Plan for ``problem``; never raises for planning failures (see :class:`PlanStatus`)."""
    config = config or PlannerConfig()
    started = time.perf_counter()
    if classical is None:
        classical = FastDownward(
            DownwardConfig(max_time=config.search_time, memory_mb=config.memory_mb)
        )
    negative = negative_test_predicates(problem)
    run = _Run(
        problem,
        config,
        classical,
        StreamStore(problem, started + config.max_time),
        compile_domain(problem, negative),
        negative,
        started,
    )
    try:
        if config.algorithm == "incremental":
            return _incremental(run)
        return _focused(run)
    except StreamFailure as e:
        return run.result(PlanStatus.ERROR, str(e))
    except PlannerNotFound as e:
        return run.result(PlanStatus.ERROR, str(e))


# ------------------------------------------------------------------------------------ focused


def _focused(run: _Run) -> PlanResult:
    store = run.store
    while run.iterations < run.config.max_iterations:
        run.iterations += 1
        evaluate_negative_tests(store, _negative_streams(run))
        if store.out_of_time():
            return run.result(PlanStatus.TIMEOUT, f"no plan within {run.config.max_time} s")
        opt = optimistic_instances(store, lambda b: True, run.config.max_level)
        found = _search(run, opt)
        if isinstance(found, PlanResult):
            return found
        if found is None:  # even the optimistic task has no plan
            return run.result(PlanStatus.UNSOLVABLE, _unsolvable_message(run))
        actions, cost = found
        needed = _stream_plan(actions, opt, run, evaluate=True)
        if not needed:
            return run.result(PlanStatus.SOLVED, "", _final_plan(run, actions, opt, cost))
        _evaluate(run, needed)
    return run.result(
        PlanStatus.UNSOLVABLE, f"no plan after {run.config.max_iterations} iterations"
    )


def _negative_streams(run: _Run) -> list[BoundStream]:
    """Non-deferred tests whose certified atoms occur negated: evaluated on every real binding."""
    return [
        b
        for b in run.problem.bound_streams.values()
        if b.schema.is_test
        and not run.deferred(b)
        and any(a.predicate in run.negative_tests for a in b.schema.certified)
    ]


def _evaluate(run: _Run, needed: list[OptInstance]) -> None:
    """Evaluate a stream plan in order; placeholders map to the real outputs as they come."""
    store = run.store
    real: dict[str, str] = {}
    for inst in needed:
        inputs = tuple(real.get(x, x) for x in inst.inputs)
        if any(is_optimistic(x) for x in inputs):
            continue  # its producer failed this time
        rec = store.record(inst.stream, inputs)
        out = store.call(rec)
        if out is not None:
            real.update(zip(inst.outputs, out, strict=True))
        if store.out_of_time():
            return


# -------------------------------------------------------------------------------- incremental


def _incremental(run: _Run) -> PlanResult:
    store = run.store
    level = 0
    while run.iterations < run.config.max_iterations:
        run.iterations += 1
        evaluate_negative_tests(store, _negative_streams(run))
        opt = optimistic_instances(store, run.deferred, run.config.max_level)
        found = _search(run, opt)
        if isinstance(found, PlanResult):
            return found
        if found is not None:
            actions, cost = found
            return run.result(PlanStatus.SOLVED, "", _final_plan(run, actions, opt, cost))
        level += 1
        if not _one_level(run):
            return run.result(PlanStatus.UNSOLVABLE, _unsolvable_message(run))
        if store.out_of_time():
            return run.result(
                PlanStatus.TIMEOUT,
                f"no plan within {run.config.max_time} s (incremental level {level})",
            )
    return run.result(
        PlanStatus.UNSOLVABLE, f"no plan after {run.config.max_iterations} iterations"
    )


def _one_level(run: _Run) -> bool:
    """Call every reachable, non-deferred, non-exhausted instance once; True if any produced."""
    store = run.store
    state = State(store.facts)
    produced = False
    for b in run.problem.bound_streams.values():
        if run.deferred(b):
            continue
        for env in list(join(b.schema.domain, state)):
            rec = store.record(b, tuple(env[v] for v in b.schema.inputs))
            if not rec.exhausted and store.call(rec) is not None:
                produced = True
            if store.out_of_time():
                return True
    return produced


# ----------------------------------------------------------------------------------- search


def _object_types(run: _Run) -> dict[str, str]:
    types = dict(run.problem.object_types)
    for name in run.store.values:
        types.setdefault(name, "object")
    return types


def _search(
    run: _Run, opt: list[OptInstance]
) -> tuple[tuple[tuple[str, tuple[str, ...]], ...], float] | PlanResult | None:
    """Search once: (actions, cost), None when the task is unsolvable, or a final result."""
    store = run.store
    facts = store.facts | store.rejected
    costs = function_values(
        run.problem, facts | {a for i in opt for a in i.certified}, run.cost_cache
    )
    task = compile_task(run.problem, facts, opt, costs, _object_types(run), run.negative_tests)
    budget = min(run.config.search_time, run.remaining())
    if budget <= 0:
        return run.result(PlanStatus.TIMEOUT, f"no plan within {run.config.max_time} s")
    res: ClassicalPlan = run.classical.solve(run.compiled.text, task.problem_text, max_time=budget)
    run.translate_time += res.translate_time
    run.search_time += res.search_time
    log.debug(
        "iteration %d: %d optimistic instances, %s", run.iterations, len(opt), res.status.value
    )
    if res.status is ClassicalStatus.SOLVED:
        return res.actions, float(res.cost or 0.0)
    if res.status is ClassicalStatus.UNSOLVABLE:
        return None
    if res.status is ClassicalStatus.TIMEOUT:
        return run.result(PlanStatus.TIMEOUT, f"classical search: {res.message}")
    return run.result(PlanStatus.ERROR, f"classical planner {res.status.value}: {res.message}")


def _stream_plan(
    actions: Iterable[tuple[str, tuple[str, ...]]],
    opt: list[OptInstance],
    run: _Run,
    evaluate: bool,
) -> list[OptInstance]:
    """The stream instances of the plan, in plan order (non-deferred ones if ``evaluate``)."""
    by_key = {(i.stream.schema.name, i.inputs + i.outputs): i for i in opt}
    out = []
    for name, args in actions:
        if not name.startswith(STREAM_ACTION_PREFIX):
            continue
        inst = by_key[(name.removeprefix(STREAM_ACTION_PREFIX), args)]
        if run.deferred(inst.stream) != evaluate:
            out.append(inst)
    return out


def _final_plan(
    run: _Run,
    actions: tuple[tuple[str, tuple[str, ...]], ...],
    opt: list[OptInstance],
    classical_cost: float,
) -> Plan:
    deferred = _stream_plan(actions, opt, run, evaluate=False)
    steps = _attach_deferred(actions, deferred)
    n_streams = sum(round(i.effort * COST_SCALE) for i in deferred) / COST_SCALE
    cost = max(0.0, classical_cost / COST_SCALE - n_streams)
    instances = tuple(StreamInstance(i.stream.schema.name, i.inputs, i.outputs) for i in deferred)
    placeholders = {o: None for i in deferred for o in i.outputs}
    certified = {a for a in run.store.facts if a not in run.problem.init}
    certified |= {a for i in deferred for a in i.certified}
    return Plan(
        steps=steps,
        cost=cost,
        objects={**run.store.values, **placeholders},
        certified=frozenset(certified),
        deferred=instances,
        deferred_facts={s: i.certified for s, i in zip(instances, deferred, strict=True)},
    )


def _attach_deferred(
    actions: tuple[tuple[str, tuple[str, ...]], ...], deferred: list[OptInstance]
) -> tuple[PlanStep, ...]:
    """Each deferred instance goes to the first later action that uses its outputs or facts,
    or else to the action right after it."""
    keyed = {
        (STREAM_ACTION_PREFIX + i.stream.schema.name, i.inputs + i.outputs): i for i in deferred
    }
    domain_steps = [
        (k, a) for k, a in enumerate(actions) if not a[0].startswith(STREAM_ACTION_PREFIX)
    ]
    owner: dict[int, list[OptInstance]] = {}
    for k, action in enumerate(actions):
        inst = keyed.get(action)
        if inst is None:
            continue
        later = [(j, a) for j, a in domain_steps if j > k]
        if not later:
            continue
        users = [
            j
            for j, (_, args) in later
            if set(inst.outputs) & set(args) or _mentions(inst.certified, args)
        ]
        owner.setdefault(users[0] if users else later[0][0], []).append(inst)
    return tuple(
        PlanStep(
            name,
            args,
            tuple(
                StreamInstance(i.stream.schema.name, i.inputs, i.outputs) for i in owner.get(j, [])
            ),
        )
        for j, (name, args) in domain_steps
    )


def _mentions(facts: tuple[Atom, ...], args: tuple[str, ...]) -> bool:
    a = set(args)
    return any(f.args and set(f.args) <= a for f in facts)


def _unsolvable_message(run: _Run) -> str:
    n = len(run.store.records)
    exhausted = sum(r.exhausted for r in run.store.records.values())
    return (
        f"no plan: the classical planner found none after {run.iterations} iteration(s); "
        f"{exhausted} of {n} stream instances exhausted"
    )
