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
the search (:func:`_resample`): a failed binding gets new samples before the task is searched
again. Not the default: measured faster on PDDLStream's pybullet/tamp, slower on the 2-D packed
family (the values drawn grow the closures; docs/pddlstream.md).

``incremental``: evaluate every stream instance once per level on the real facts, then search.

Plan quality (:mod:`~llmpas.planning.quality`): the config's quality names the search for the
first plan and, for ``anytime``, the searches bounded by the incumbent's cost that look for
cheaper plans afterwards; a cheaper optimistic plan becomes the incumbent only once its streams
are evaluated and it replays over the real values (:func:`_realize`). After a new incumbent,
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
import resource
import time
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field

from llmpas.language.bindings import BoundStream
from llmpas.language.logic import Atom, FuncTerm, Substitution
from llmpas.language.problem import Problem, missing_function_value
from llmpas.language.semantics import Semantics, State, preimage, replay
from llmpas.planning import registry
from llmpas.planning.compile import (
    COST_SCALE,
    CompiledDomain,
    compile_domain,
    compile_goal,
    compile_task,
    external_facts,
    function_values,
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
    certified_by_fluent,
    context,
    fluent_streams,
    unsupported_fluents,
)
from llmpas.planning.guards import guard_quantifiers
from llmpas.planning.instances import (
    Closure,
    LimitReached,
    OptInstance,
    Record,
    StreamFailure,
    StreamStore,
    evaluate_negative_tests,
    is_optimistic,
    join,
    negative_test_predicates,
    optimistic_instances,
)
from llmpas.planning.quality import QUALITIES, Quality
from llmpas.planning.result import (
    Improvement,
    Plan,
    PlanResult,
    PlanStats,
    PlanStatus,
    PlanStep,
    StreamInstance,
)

log = logging.getLogger(__name__)


@dataclass
class Run:
    """Mutable bookkeeping of one call to :func:`solve`: what a registered algorithm
    (:data:`~llmpas.planning.registry.ALGORITHMS`) works on."""

    problem: Problem
    config: PlannerConfig
    given: ClassicalPlanner | None  # the caller's planner (used for every search), or None
    store: StreamStore
    compiled: CompiledDomain
    negative_tests: set[str]
    assumed: frozenset[str]  # deferred streams: assumed, never evaluated here
    started: float
    inline: frozenset[str] = frozenset()  # deferred streams compiled into the actions
    domain_text: str = ""  # what the classical planner gets (quantifiers guarded)
    iterations: int = 0
    complexity_limit: int | None = None  # focused: set, raised when a search fails (_widen)
    evidence: int = 1  # focused: raised when a search fails (see _widen)
    translate_time: float = 0.0
    search_time: float = 0.0
    cost_cache: dict[FuncTerm, float] = field(default_factory=dict)
    costs: dict[FuncTerm, float] = field(default_factory=dict)  # function values, last search
    started_cpu: float = 0.0
    improvements: list[Improvement] = field(default_factory=list)
    idle: int = 0  # anytime: iterations since the last cheaper plan
    planners: dict[str, ClassicalPlanner] = field(default_factory=dict)  # by search string
    fluent: dict[str, BoundStream] = field(default_factory=dict)  # evaluated fluent streams
    depth: int | None = None  # focused: the closure's depth near a new incumbent (None: max)
    shared: bool = False  # focused: placeholders shared (config, or a closure too large unshared)

    @property
    def fluent_by_predicate(self) -> dict[str, str]:
        return certified_by_fluent(self.fluent)

    @property
    def quality(self) -> Quality:
        return QUALITIES[self.config.quality]

    @property
    def incumbent(self) -> Plan | None:
        return self.improvements[-1].plan if self.improvements else None

    def bound(self) -> int | None:
        """Fast Downward's cost bound for the next search: the incumbent's scaled cost."""
        best = self.incumbent
        return None if best is None else round(best.cost * COST_SCALE)

    def classical(self) -> ClassicalPlanner:
        """The planner for the next search: the caller's, or Fast Downward with the quality's
        search for the first plan (the config's ``search`` if set) or for a cheaper one."""
        if self.given is not None:
            return self.given
        n = len(self.improvements)
        explicit = self.config.search if n == 0 else None
        command = explicit or self.quality.search(n).command(self.bound())
        if command not in self.planners:
            make = registry.classical_planner(self.config.classical).load()
            self.planners[command] = make(command, self.config)
        return self.planners[command]

    def deferred(self, b: BoundStream) -> bool:
        return b.schema.name in self.assumed

    def instantiated(self, b: BoundStream) -> bool:
        """Whether the stream gets optimistic instances (inlined ones need none, and streams
        with ``p_success=0`` are never assumed)."""
        return b.schema.name not in self.inline and not b.info.never_assumed

    def hidden(self) -> set[str]:
        """The real objects kept out of the classical task: when the algorithm set a complexity
        limit (focused planning), those above it (the values of samplers called many times wait
        until a search fails without them, as their optimistic instances do)."""
        if self.complexity_limit is None:
            return set()
        return set(self.store.above(self.complexity_limit))

    def remaining(self) -> float:
        return self.config.max_time - (time.perf_counter() - self.started)

    def stats(self) -> PlanStats:
        return PlanStats(
            algorithm=self.config.algorithm,
            quality=self.config.quality,
            iterations=self.iterations,
            stream_calls=dict(self.store.calls),
            stream_time=self.store.time,
            translate_time=self.translate_time,
            search_time=self.search_time,
            total_time=time.perf_counter() - self.started,
        )

    def result(self, status: PlanStatus, message: str, plan: Plan | None = None) -> PlanResult:
        """The call's result; once a plan was found (anytime), a limit or failure ends the
        search for cheaper ones and returns the cheapest plan, the reason in the message."""
        best = self.incumbent
        if status is not PlanStatus.SOLVED and best is not None:
            status, plan = PlanStatus.SOLVED, best
            message = f"cheapest of {len(self.improvements)} plan(s) kept; stopped: {message}"
        return PlanResult(status, plan, self.stats(), message, tuple(self.improvements))

    def accept(self, plan: Plan) -> PlanResult | None:
        """A plan whose streams are evaluated (and which replays): the result, unless the
        quality looks for cheaper plans (then None: planning goes on with a cost bound)."""
        best = self.incumbent
        if best is None or plan.cost < best.cost:
            wall, cpu = time.perf_counter() - self.started, _cpu() - self.started_cpu
            calls = self.store.calls.total()
            self.improvements.append(
                Improvement(wall, cpu, plan.cost, plan, self.iterations, calls)
            )
            self.idle = 0
            depth = self.quality.improve_depth  # read by focused planning (its closure)
            if depth is not None:
                self.depth = depth if depth < self.config.max_level else None
            log.info(
                "plan %d: cost %g, %d steps, after %.2f s (%.2f s CPU)",
                len(self.improvements), plan.cost, len(plan), wall, cpu,
            )  # fmt: skip
        if not self.quality.anytime:
            return self.result(PlanStatus.SOLVED, "", self.incumbent)
        return None

    def patience_left(self) -> PlanResult | None:
        """Anytime: the incumbent once ``patience`` iterations brought no cheaper plan."""
        if self.incumbent is None:
            return None
        if self.idle >= self.config.patience:
            return self.result(
                PlanStatus.TIMEOUT, f"{self.idle} iterations without a cheaper plan (patience)"
            )
        self.idle += 1
        return None


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
        started_cpu=_cpu(),
        fluent=fluent,
        shared=config.share_placeholders,
    )
    run.domain_text = guard_quantifiers(run.compiled.domain).to_pddl()
    try:
        plan = registry.algorithm(config.algorithm).load()
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


# ------------------------------------------------------------------------------------ focused


def plan_focused(run: Run) -> PlanResult:
    """The ``focused`` algorithm (see the module's documentation)."""
    return _focused(run, queue=False)


def plan_skeletons(run: Run) -> PlanResult:
    """The ``skeletons`` algorithm: ``focused`` with the skeleton queue (module documentation),
    as PDDLStream's adaptive algorithm; what ``llmpas.pddlstream`` runs for ``adaptive``."""
    return _focused(run, queue=True)


def _focused(run: Run, queue: bool) -> PlanResult:
    store = run.store
    evaluated: _Evaluated | None = None  # the last plan whose streams were evaluated
    skeletons: list[_Evaluated] = []  # evaluated plans that did not hold: to draw again
    run.complexity_limit = run.config.max_level
    while run.iterations < run.config.max_iterations:
        run.iterations += 1
        stop = run.patience_left()
        if stop is not None:
            return stop
        evaluate_negative_tests(store, _negative_streams(run))
        if store.out_of_time():
            return _time_limit(run)
        depth = run.depth
        closure, opt = _closure(run)
        realized = None if evaluated is None else _realize(run, evaluated, opt)
        if queue and realized is None and evaluated is not None and _resamplable(evaluated):
            skeletons = [evaluated, *skeletons][:_MAX_SKELETONS]
        if realized is None and skeletons and run.depth is None:
            realized = _resample(run, skeletons, opt)
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
                return run.result(PlanStatus.UNSOLVABLE, _unsolvable_message(run))
            if _widen(run, closure) or _eager_pending(run):
                continue
            return run.result(PlanStatus.UNSOLVABLE, _unsolvable_message(run))
        actions, cost = found
        per_step, trace = _replayed(_retrace(run, actions, opt))
        needed = [i for insts in per_step for i in insts if not run.deferred(i.stream)]
        if not needed:
            done = run.accept(_final_plan(run, actions, per_step, cost, trace))
            if done is not None:
                return done
            continue
        # fluent streams last, step by step: their contexts need the plan's real values
        needed = [i for i in needed if i.step is None] + [i for i in needed if i.step is not None]
        real = _evaluate(run, needed, trace)
        evaluated = _Evaluated(
            actions, [i for insts in per_step for i in insts], trace, real, tuple(needed)
        )
    return _iteration_limit(run)


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
    _update_costs(run, opt)
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


def _time_limit(run: Run, where: str = "") -> PlanResult:
    return run.result(
        PlanStatus.TIMEOUT,
        f"time limit reached: {'' if run.incumbent else 'no plan within '}"
        f"max_time={run.config.max_time:g} s" + where,
    )


def _iteration_limit(run: Run) -> PlanResult:
    if run.store.out_of_time():  # the last iteration may have been cut short by the clock
        return _time_limit(run)
    n = run.config.max_iterations
    return run.result(
        PlanStatus.LIMIT,
        f"iteration limit reached: no plan after max_iterations={n} iterations "
        f"({sum(run.store.calls.values())} stream calls)",
    )


def _negative_streams(run: Run) -> list[BoundStream]:
    """Non-deferred tests whose certified atoms occur negated, streams never assumed
    (``p_success=0``) and eager ones: evaluated on every real binding before a search."""
    return [
        b
        for b in run.problem.bound_streams.values()
        if b.info.never_assumed
        or b.info.eager
        or (
            b.schema.is_test
            and not run.deferred(b)
            and any(a.predicate in run.negative_tests for a in b.schema.certified)
        )
    ]


def _eager_pending(run: Run) -> bool:
    """Whether a stream evaluated before each search (``_negative_streams``) has a real binding
    not called yet: facts it or another produced (outputs, or reported :class:`Facts`) since
    the evaluation before this search. The next iteration calls them."""
    state = State(run.store.facts)
    for b in _negative_streams(run):
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


def _evaluate(
    run: Run, needed: list[OptInstance], trace: _Trace, effort: int = 1
) -> dict[int, dict[str, str]]:
    """Evaluate a stream plan in order; each placeholder input takes the real output of the
    producer the trace chose for it. Returns, per evaluated instance (by id), its placeholder
    outputs -> the real names.

    When an instance fails (a test rejects, a function finds nothing), the plan's skeleton is
    kept and the binding is searched further, as PDDLStream's adaptive algorithm does: the most
    recently evaluated sampler upstream of the failure draws a new value and only what depends
    on it is evaluated again, at most ``_RETRIES`` times per failed instance. For a fluent
    stream, the samplers of the values in its context (where the plan put things before) are
    upstream too, and each retry takes the next one back."""
    binder = _Binder(run, needed, trace)
    position, retries = 0, Counter[int]()
    while position < len(needed):
        if binder.bind(position) or retries[position] >= _RETRIES * effort:
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


class _Binder:
    """The bindings of one stream plan, with backtracking to upstream samplers."""

    def __init__(self, run: Run, needed: list[OptInstance], trace: _Trace) -> None:
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
        return _context(sem, facts, inst.stream.schema.fluents)

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
        if failed.outputs:
            return True  # a function or sampler found nothing: try other inputs
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
class _Evaluated:
    """A plan over placeholders whose stream plan was evaluated (``effort``: how many times;
    a skeleton of the queue is evaluated again with one more)."""

    actions: tuple[tuple[str, tuple[str, ...]], ...]
    instances: list[OptInstance]  # producers first
    trace: _Trace
    real: dict[int, dict[str, str]]  # id(evaluated instance) -> placeholder -> real name
    needed: tuple[OptInstance, ...] = ()  # what was evaluated, in order
    effort: int = 1


_MAX_SKELETONS = 4  # skeletons kept to draw again (the newest first)
_MAX_EFFORT = 4  # evaluations of one skeleton, the first included


def _resamplable(done: _Evaluated) -> bool:
    """Whether a plan that did not hold is kept as a skeleton: it needed streams and has effort
    left. Fluent instances are evaluated again in the contexts the new values give (the
    binding computes each one's context from the plan's steps before it)."""
    return bool(done.needed) and done.effort < _MAX_EFFORT


def _resample(run: Run, skeletons: list[_Evaluated], opt: list[OptInstance]) -> Plan | None:
    """Evaluate the oldest kept skeleton again, with more effort (more values drawn per
    failure): the plan over the new values if it holds (it leaves the queue), else None (it
    goes back to the end of the queue while it has effort left). A failed binding is so
    retried with new samples before the task is searched again, and the skeletons kept are
    drawn in turn, one per iteration, interleaved with the searches."""
    skeleton = skeletons.pop()
    effort = skeleton.effort + 1
    needed = list(skeleton.needed)
    real = _evaluate(run, needed, skeleton.trace, effort)
    again = dataclasses.replace(skeleton, real=real, effort=effort)
    log.debug(
        "iteration %d: skeleton of %d steps drawn again (effort %d): %d of %d bound",
        run.iterations, len(skeleton.actions), effort, len(real), len(needed),
    )  # fmt: skip
    plan = None
    if len(real) == len(needed):
        # as before a search: the tests read negated, on the new values too
        evaluate_negative_tests(run.store, _negative_streams(run))
        _update_costs(run, opt)  # the new values' function values
        plan = _realize(run, again, opt)
    if plan is None and _resamplable(again):
        skeletons.insert(0, again)
    return plan


def _realize(run: Run, done: _Evaluated, opt: list[OptInstance]) -> Plan | None:
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
    traced = _retrace(run, tuple(actions), opt)
    if traced is None:
        return None
    per_step, trace = traced
    if any(not run.deferred(i.stream) for insts in per_step for i in insts):
        return None
    log.debug("iteration %d: the evaluated plan holds with the real values", run.iterations)
    cost = _plan_cost(run, tuple(actions), opt)
    return _final_plan(run, tuple(actions), per_step, cost, trace)


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
    sem = Semantics(run.compiled.domain, _object_types(run, opt), scaled)
    init = run.store.facts | run.store.rejected | {a for i in opt for a in i.certified}
    return replay(sem, init | run.store.fluent_facts.keys(), actions).cost


# -------------------------------------------------------------------------------- incremental


def plan_incremental(run: Run) -> PlanResult:
    """The ``incremental`` algorithm (see the module's documentation)."""
    store = run.store
    level = 0
    while run.iterations < run.config.max_iterations:
        run.iterations += 1
        stop = run.patience_left()
        if stop is not None:
            return stop
        evaluate_negative_tests(store, _negative_streams(run))
        opt = optimistic_instances(
            store, lambda b: run.deferred(b) and run.instantiated(b), run.config.max_level
        )
        _update_costs(run, opt)
        found = _search(run, opt)
        if isinstance(found, PlanResult):
            return found
        if found is not None:
            actions, cost = found
            per_step, trace = _replayed(_retrace(run, actions, opt))
            done = run.accept(_final_plan(run, actions, per_step, cost, trace))
            if done is not None:
                return done
            continue  # anytime: search this level again for a cheaper plan
        if run.incumbent is not None and not run.quality.keep_sampling:
            return run.result(PlanStatus.UNSOLVABLE, _unsolvable_message(run))
        level += 1
        if not _one_level(run):
            return run.result(PlanStatus.UNSOLVABLE, _unsolvable_message(run))
        if store.out_of_time():
            return _time_limit(run, f" (incremental level {level})")
    return _iteration_limit(run)


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


# ----------------------------------------------------------------------------------- search


def _object_types(
    run: Run, opt: list[OptInstance], hidden: set[str] | None = None
) -> dict[str, str]:
    """Every object's type, but those ``hidden`` from the classical task (the semantics that
    check plans range over all of them)."""
    types = dict(run.problem.object_types)
    for name in run.store.values:
        if not hidden or name not in hidden:
            types.setdefault(name, "object")
    for i in opt:
        types.update(dict.fromkeys(i.outputs, "object"))
    return types


def _update_costs(run: Run, opt: list[OptInstance]) -> None:
    """Function values for the real facts and the optimistic ones of ``opt``."""
    store = run.store
    run.costs = function_values(
        run.problem,
        store.facts
        | store.rejected
        | store.fluent_facts.keys()
        | {a for i in opt for a in i.certified},
        run.cost_cache,
        lambda n: store.values.get(n, n),
    )


def _search(
    run: Run, opt: list[OptInstance]
) -> tuple[tuple[tuple[str, tuple[str, ...]], ...], float] | PlanResult | None:
    """Search once (costs from :func:`_update_costs`): (actions, cost), None when the task is
    unsolvable, or a final result."""
    hidden = run.hidden()
    store = run.store
    task = compile_task(
        run.problem,
        {a for a in store.facts | store.rejected if hidden.isdisjoint(a.args)}
        | block_facts(store.blocks, store.exact, hidden),
        opt,
        {t: v for t, v in run.costs.items() if hidden.isdisjoint(t.args)},
        _object_types(run, opt, hidden),
        run.negative_tests,
    )
    budget = min(run.config.search_time, run.remaining())
    if budget <= 0:
        return _time_limit(run)
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


# ---------------------------------------------------------------------------------- retrace


class _Trace:
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


def _retrace(
    run: Run, actions: tuple[tuple[str, tuple[str, ...]], ...], opt: list[OptInstance]
) -> tuple[list[list[OptInstance]], _Trace] | None:
    """Per plan step (plus one last entry for the goal), the optimistic instances it relies on,
    producers first, each instance listed once (at its first use); None if the plan is not
    valid over the real and optimistic facts."""
    store = run.store
    trace = _Trace(opt, store.facts, run.fluent)
    trace.actions = actions
    sem = Semantics(run.compiled.domain, _object_types(run, opt), run.costs)
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
            fluents = _context(sem, states[k], run.fluent[name].schema.fluents)
            if store.holds_in(a, fluents):
                here[a] = fluents
            elif a not in trace.certifiers:
                return None  # a fluent stream's fact outside the context it was certified in
        trace.in_context.append(here)
        out.append(trace.step(k, sorted(facts - here.keys()), args))
    return out, trace


def _context(sem: Semantics, facts: Iterable[Atom], fluents: Iterable[str]) -> frozenset[Atom]:
    """The facts of the ``fluents`` predicates in the state of base ``facts`` (derived ones
    computed when a fluent predicate is derived)."""
    preds = set(fluents)
    if preds & sem.domain.derived_names:
        return context(sem.closure(facts).facts, preds)
    return context(facts, preds)


def _replayed(
    traced: tuple[list[list[OptInstance]], _Trace] | None,
) -> tuple[list[list[OptInstance]], _Trace]:
    if traced is None:
        raise RuntimeError("the classical plan does not replay under the domain semantics")
    return traced


def _final_plan(
    run: Run,
    actions: tuple[tuple[str, tuple[str, ...]], ...],
    per_step: list[list[OptInstance]],
    classical_cost: float,
    trace: _Trace,
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


def _cpu() -> float:
    """CPU seconds of this process and its finished children (the Fast Downward searches)."""
    own, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _unsolvable_message(run: Run) -> str:
    records = [*run.store.records.values(), *run.store.fluent_records.values()]
    n = len(records)
    exhausted = sum(r.exhausted for r in records)
    missing = missing_function_value(run.problem)
    return (
        f"{'no cheaper plan' if run.incumbent else 'no plan'}: the classical planner found "
        f"none after {run.iterations} iteration(s); "
        f"{exhausted} of {n} stream instances exhausted" + (f" ({missing})" if missing else "")
    )
