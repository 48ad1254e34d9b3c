"""Stream-based TAMP planning on a classical planner: ``focused`` and ``incremental``.

``focused`` (optimistic, in PDDLStream's terms *focused/adaptive*): every stream instance that
could apply gets placeholder outputs and its certified facts are assumed; the classical planner
plans as if all streams succeeded; the plan's preimage (the facts it relies on, through derived
predicates) says which stream instances it needs; only those are evaluated, producers first; an
evaluated instance is disabled until a search fails (then all are re-enabled); repeat until a plan
needs no unevaluated stream.

``skeletons``: ``focused`` with a skeleton queue, as PDDLStream's adaptive algorithm: an
evaluated plan that does not hold (a binding failed, or its values fail a test the plan reads)
is kept as a *skeleton* and drawn again with growing effort, one skeleton per iteration before
the search (:func:`resample`): a failed binding gets new samples before the task is searched
again. Not the default: measured faster on PDDLStream's pybullet/tamp, slower on the 2-D packed
family (the values drawn grow the closures; docs/pddlstream.md).

``incremental``: evaluate every stream instance once per level on the real facts, then search.

Plan quality (:mod:`~llmpas.planning.quality`): the config's quality names the search for the
first plan and, for ``anytime``, the searches bounded by the incumbent's cost that look for
cheaper plans afterwards; a cheaper optimistic plan becomes the incumbent only once its streams
are evaluated and it replays over the real values (:func:`realize`). After a new incumbent,
the optimistic closure first stops at the quality's ``improve_depth`` (streams on real values
only), and goes back to full depth once a search there finds nothing cheaper.

Streams with ``:fluents`` (focused only; :mod:`~llmpas.planning.fluents`): a plan's instance of
one is evaluated per step that uses it, after the plan's other streams, with the fluent facts of
the state before that step; its facts hold only in that context, and a failure blocks it in the
states where the context's facts hold.

In both, *deferred* streams are never evaluated here: the plan keeps their placeholders and lists,
per action, the deferred instances the executor must satisfy.

Every decision is taken on counts (iterations, stream calls, a sampler's ``None`` in a row; see
:class:`~llmpas.planning.config.PlannerConfig`), except where a time limit fires: that ends the
call with status ``timeout``, whatever else was found so far.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections import Counter

from llmpas.language.problem import Problem
from llmpas.language.semantics import State
from llmpas.planning import planner_registry
from llmpas.planning.compile import (
    compile_domain,
    compile_task,
    inlinable_streams,
)
from llmpas.planning.config import PlannerConfig
from llmpas.planning.downward import (
    ClassicalPlan,
    ClassicalPlanner,
    ClassicalStatus,
    PlannerNotFound,
    TaskPlanner,
)
from llmpas.planning.fluents import (
    block_facts,
    fluent_streams,
    unsupported_fluents,
)
from llmpas.planning.guards import guard_quantifiers
from llmpas.planning.instances import (
    Closure,
    LimitReached,
    OptInstance,
    StreamFailure,
    StreamStore,
    evaluate_negative_tests,
    join,
    negative_test_predicates,
    optimistic_instances,
)
from llmpas.planning.plan_tests import (
    check_plan_tests,
    lazy_tests,
    unread_tests,
    with_plan_tests,
)
from llmpas.planning.plan_trace import final_plan, replayed, retrace
from llmpas.planning.planner_run import (
    Run,
    cpu_seconds,
    iteration_limit,
    negative_streams,
    object_types,
    time_limit,
    unsolvable_message,
    update_costs,
)
from llmpas.planning.result import (
    PlanResult,
    PlanStats,
    PlanStatus,
)
from llmpas.planning.skeletons import (
    MAX_SKELETONS,
    Evaluated,
    evaluate_streams,
    realize,
    resamplable,
    resample,
)

log = logging.getLogger(__name__)


def solve(
    problem: Problem,
    config: PlannerConfig | None = None,
    classical: ClassicalPlanner | None = None,
) -> PlanResult:
    """Plan for ``problem``; never raises for planning failures (see :class:`PlanStatus`).

    With ``share_placeholders``, a task found unsolvable is planned again from scratch with one
    placeholder per instance (within what is left of ``max_time``), so that sharing never turns
    a solvable task into an "unsolvable" verdict."""
    config = config or PlannerConfig()
    started = time.perf_counter()
    result = _solve_once(problem, config, classical, started)
    if not (config.share_placeholders and result.status is PlanStatus.UNSOLVABLE):
        return result
    left = config.max_time - (time.perf_counter() - started)
    if left <= 0:
        return result
    log.debug("shared placeholders found no plan; planning again with one per instance")
    unique = dataclasses.replace(config, share_placeholders=False, max_time=left)
    second = _solve_once(problem, unique, classical, time.perf_counter())
    return dataclasses.replace(second, stats=_added(result.stats, second.stats))


def _added(a: PlanStats, b: PlanStats) -> PlanStats:
    calls = Counter(a.stream_calls)
    calls.update(b.stream_calls)
    return PlanStats(
        algorithm=b.algorithm,
        quality=b.quality,
        iterations=a.iterations + b.iterations,
        stream_calls=dict(calls),
        stream_time=a.stream_time + b.stream_time,
        translate_time=a.translate_time + b.translate_time,
        search_time=a.search_time + b.search_time,
        total_time=a.total_time + b.total_time,
    )


def _solve_once(
    problem: Problem,
    config: PlannerConfig,
    classical: ClassicalPlanner | None,
    started: float,
) -> PlanResult:
    negative = negative_test_predicates(problem)
    assumed = frozenset(
        b.schema.name for b in problem.bound_streams.values() if config.defer and b.info.deferred
    )
    inline = inlinable_streams(problem, assumed)
    refused = unsupported_fluents(problem, config.algorithm, assumed, negative)
    if refused is not None:
        return PlanResult(
            PlanStatus.ERROR, None, PlanStats(config.algorithm, config.quality), refused
        )
    fluent = fluent_streams(problem, assumed)
    run = Run(
        problem,
        config,
        classical,
        StreamStore(
            problem,
            started + config.max_time,
            config.max_stream_calls,
            config.max_empty_samples,
            init_identity=config.init_identity,
        ),
        compile_domain(problem, negative, inline, fluent),
        negative,
        assumed,
        started,
        inline=inline,
        started_cpu=cpu_seconds(),
        fluent=fluent,
        shared=config.share_placeholders,
    )
    run.domain_text = guard_quantifiers(run.compiled.domain).to_pddl()
    try:
        plan = planner_registry.algorithm(config.algorithm).load()
        result: PlanResult = plan(run)
        return _shared_verdict(run, result)
    except StreamFailure as e:
        return run.result(PlanStatus.ERROR, str(e))
    except LimitReached as e:
        return run.result(PlanStatus.LIMIT, str(e))
    except PlannerNotFound as e:
        return run.result(PlanStatus.ERROR, str(e))


def _shared_verdict(run: Run, result: PlanResult) -> PlanResult:
    """No plan over placeholders shared only because one per instance exceeded
    ``max_instances`` is no verdict (sharing alone is not complete): a ``limit``, naming it."""
    if result.status is not PlanStatus.UNSOLVABLE or not run.shared:
        return result
    if run.config.share_placeholders:
        return result  # solve() plans again with one placeholder per instance
    return dataclasses.replace(
        result,
        status=PlanStatus.LIMIT,
        message=f"{result.message}, over shared placeholders: one per stream instance would "
        f"exceed max_instances={run.config.max_instances}",
    )


def plan_focused(run: Run) -> PlanResult:
    """The ``focused`` algorithm (see the module's documentation)."""
    return _focused(run, queue=False)


def plan_skeletons(run: Run) -> PlanResult:
    """The ``skeletons`` algorithm: ``focused`` with the skeleton queue (module documentation),
    as PDDLStream's adaptive algorithm; what ``llmpas.pddlstream`` runs for ``adaptive``."""
    return _focused(run, queue=True)


def _focused(run: Run, queue: bool) -> PlanResult:
    store = run.store
    evaluated: Evaluated | None = None  # the last plan whose streams were evaluated
    skeletons: list[Evaluated] = []  # evaluated plans that did not hold: to draw again
    run.complexity_limit = run.config.max_level
    run.lazy = lazy_tests(run) if run.config.lazy_tests else frozenset()
    run.unread = unread_tests(run)
    while run.iterations < run.config.max_iterations:
        run.iterations += 1
        stop = run.patience_left()
        if stop is not None:
            return stop
        evaluate_negative_tests(store, negative_streams(run))
        if store.out_of_time():
            return time_limit(run)
        depth = run.depth
        closure, opt = _closure(run)
        realized = None if evaluated is None else realize(run, evaluated, opt)
        if queue and realized is None and evaluated is not None and resamplable(evaluated):
            skeletons = [evaluated, *skeletons][:MAX_SKELETONS]
        if realized is None and skeletons and run.depth is None:
            realized = resample(run, skeletons, opt)
        evaluated = None
        if realized is not None:
            done = run.accept(realized)
            if done is not None:
                return done
            if run.depth != depth:  # a new incumbent: search near it first
                closure, opt = _closure(run)
        found = _search(run, opt)
        if isinstance(found, PlanResult):
            return found
        if found is None and run.depth is not None:  # nothing cheaper near it: full depth
            log.debug("iteration %d: no cheaper plan at depth %d", run.iterations, run.depth)
            run.depth = None
            continue
        if found is None:  # no plan (no cheaper plan) even with every enabled instance assumed
            if run.incumbent is not None and not run.quality.keep_sampling:
                return run.result(PlanStatus.UNSOLVABLE, unsolvable_message(run))
            if _widen(run, closure) or _eager_pending(run):
                continue
            return run.result(PlanStatus.UNSOLVABLE, unsolvable_message(run))
        actions, cost = found
        per_step, trace = replayed(retrace(run, actions, opt))
        needed = [i for insts in per_step for i in insts if not run.deferred(i.stream)]
        if not needed:
            if check_plan_tests(run, actions, opt):  # a test it reads negated failed
                traced = retrace(run, actions, opt)
                if traced is None or any(
                    not run.deferred(i.stream) for insts in traced[0] for i in insts
                ):
                    continue
                per_step, trace = traced
            done = run.accept(final_plan(run, actions, per_step, cost, trace))
            if done is not None:
                return done
            continue
        # fluent streams last, step by step: their contexts need the plan's real values
        needed = [i for i in needed if i.step is None] + [i for i in needed if i.step is not None]
        needed = with_plan_tests(run, actions, opt, trace, needed)
        real = evaluate_streams(run, needed, trace)
        evaluated = Evaluated(
            actions, [i for insts in per_step for i in insts], trace, real, tuple(needed)
        )
    return iteration_limit(run)


def _closure(run: Run) -> tuple[Closure, list[OptInstance]]:
    """The optimistic closure for the next search (within the complexity limit, and the
    depth of an improving search), with the function values it needs. One placeholder per
    instance unless the config shares them, or until a closure would exceed ``max_instances``
    so: then they are shared for the rest of the run (a closure too large even so: the
    :class:`LimitReached` ends the run)."""
    try:
        closure, opt = _build_closure(run)
    except LimitReached:
        if run.shared:
            raise
        run.shared = True  # for the rest of the run: the next closures are as large
        log.info(
            "iteration %d: more than %d optimistic instances with one placeholder per "
            "instance; placeholders are shared from now on",
            run.iterations,
            run.config.max_instances,
        )
        closure, opt = _build_closure(run)
    update_costs(run, opt)
    return closure, opt


def _build_closure(run: Run) -> tuple[Closure, list[OptInstance]]:
    closure = Closure(run.complexity_limit, run.evidence)
    opt = optimistic_instances(
        run.store,
        run.instantiated,
        run.config.max_level if run.depth is None else run.depth,
        limit=run.config.max_instances,
        shared=lambda b: run.shared and not run.deferred(b),
        closure=closure,
    )
    return closure, opt


def _eager_pending(run: Run) -> bool:
    """Whether a stream evaluated before each search (``negative_streams``) has a real binding
    not called yet: facts it or another produced (outputs, or reported :class:`Facts`) since
    the evaluation before this search. The next iteration calls them."""
    state = State(run.store.facts)
    for b in negative_streams(run):
        for env in join(b.schema.domain, state):
            rec = run.store.records.get((b.schema.name, tuple(env[v] for v in b.schema.inputs)))
            if rec is None or (rec.calls == 0 and not rec.exhausted):
                return True
    return False


def _widen(run: Run, closure: Closure) -> bool:
    """After a failed search: re-enable the evaluated instances and raise the complexity limit
    (to the lowest complexity left out, at least by one), as PDDLStream's adaptive algorithm
    does; only when neither changes anything, ask for one more failure before a test on a new
    sample is no longer assumed to pass. False when nothing changes: no plan exists even
    optimistically."""
    reenabled = _reenable(run.store)
    if closure.pruned is not None:
        run.complexity_limit = max((run.complexity_limit or 0) + 1, closure.pruned)
    elif not reenabled and closure.withheld:
        run.evidence += 1
    log.debug(
        "iteration %d: complexity limit %s, evidence %d",
        run.iterations,
        run.complexity_limit,
        run.evidence,
    )
    return reenabled or closure.narrowed


def _reenable(store: StreamStore) -> bool:
    """Re-enable every called, non-exhausted instance and lift the blocks of fluent streams;
    True when any was disabled or blocked."""
    disabled = [r for r in store.records.values() if not r.enabled and not r.exhausted]
    for r in disabled:
        r.enabled = True
    unblocked = store.unblock()
    return bool(disabled) or unblocked


def plan_incremental(run: Run) -> PlanResult:
    """The ``incremental`` algorithm (see the module's documentation)."""
    store = run.store
    level = 0
    while run.iterations < run.config.max_iterations:
        run.iterations += 1
        stop = run.patience_left()
        if stop is not None:
            return stop
        evaluate_negative_tests(store, negative_streams(run))
        opt = optimistic_instances(
            store, lambda b: run.deferred(b) and run.instantiated(b), run.config.max_level
        )
        update_costs(run, opt)
        found = _search(run, opt)
        if isinstance(found, PlanResult):
            return found
        if found is not None:
            actions, cost = found
            per_step, trace = replayed(retrace(run, actions, opt))
            done = run.accept(final_plan(run, actions, per_step, cost, trace))
            if done is not None:
                return done
            continue  # anytime: search this level again for a cheaper plan
        if run.incumbent is not None and not run.quality.keep_sampling:
            return run.result(PlanStatus.UNSOLVABLE, unsolvable_message(run))
        level += 1
        if not _one_level(run):
            return run.result(PlanStatus.UNSOLVABLE, unsolvable_message(run))
        if store.out_of_time():
            return time_limit(run, f" (incremental level {level})")
    return iteration_limit(run)


def _one_level(run: Run) -> bool:
    """Call every reachable, non-deferred, non-exhausted instance once; True if any produced,
    or may still produce (a sampler that yielded only ``None`` this time)."""
    store = run.store
    state = State(store.facts)
    known = len(store.facts)
    produced = False
    for b in run.problem.bound_streams.values():
        if run.deferred(b):
            continue
        for env in list(join(b.schema.domain, state)):
            rec = store.record(b, tuple(env[v] for v in b.schema.inputs))
            if not rec.exhausted and (store.call(rec) is not None or not rec.exhausted):
                produced = True
            if store.out_of_time():
                return True
    return produced or len(store.facts) > known  # reported facts (WildOutput) are progress


def _search(
    run: Run, opt: list[OptInstance]
) -> tuple[tuple[tuple[str, tuple[str, ...]], ...], float] | PlanResult | None:
    """Search once (costs from :func:`update_costs`): (actions, cost), None when the task is
    unsolvable, or a final result."""
    hidden = run.hidden()
    store = run.store
    task = compile_task(
        run.problem,
        {a for a in store.facts | store.rejected if hidden.isdisjoint(a.args)}
        | block_facts(store.blocks, store.exact, hidden),
        opt,
        {t: v for t, v in run.costs.items() if hidden.isdisjoint(t.args)},
        object_types(run, opt, hidden),
        run.negative_tests,
    )
    budget = min(run.config.search_time, run.remaining())
    if budget <= 0:
        return time_limit(run)
    classical = run.classical()
    res: ClassicalPlan = (
        classical.solve_task(run.domain_text, task, max_time=budget)
        if isinstance(classical, TaskPlanner)
        else classical.solve(run.domain_text, task.text, max_time=budget)
    )
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
        return run.result(PlanStatus.TIMEOUT, f"classical planner: {res.message}")
    if res.status is ClassicalStatus.CRASHED:
        return run.result(PlanStatus.CRASHED, f"classical planner: {res.message}")
    return run.result(PlanStatus.ERROR, f"classical planner {res.status.value}: {res.message}")
