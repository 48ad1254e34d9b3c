"""The bookkeeping of one call to :func:`~llmpas.planning.tamp.solve` (:class:`Run`): what a
registered algorithm works on, and the helpers every algorithm shares (limits, the tests read
negated, function values, object types).
"""

from __future__ import annotations

import logging
import resource
import time
from dataclasses import dataclass, field

from llmpas.language.bindings import BoundStream
from llmpas.language.logic import FuncTerm
from llmpas.language.problem import Problem, missing_function_value
from llmpas.planning import planner_registry
from llmpas.planning.compile import (
    COST_SCALE,
    CompiledDomain,
    function_values,
)
from llmpas.planning.config import PlannerConfig
from llmpas.planning.downward import (
    ClassicalPlanner,
)
from llmpas.planning.fluents import (
    certified_by_fluent,
)
from llmpas.planning.instances import (
    OptInstance,
    StreamStore,
)
from llmpas.planning.quality import QUALITIES, Quality
from llmpas.planning.result import (
    Improvement,
    Plan,
    PlanResult,
    PlanStats,
    PlanStatus,
)

log = logging.getLogger(__name__)


@dataclass
class Run:
    """Mutable bookkeeping of one call to :func:`solve`: what a registered algorithm
    (:data:`~llmpas.planning.planner_registry.ALGORITHMS`) works on."""

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
    #: focused: tests read negated that are evaluated for a plan's bindings only (plan_tests)
    lazy: frozenset[str] = frozenset()
    #: focused: lazy tests whose certified atoms no formula reads positively: no optimistic
    #: instances (what a plan needs of them is their rejections' absence, checked per plan)
    unread: frozenset[str] = frozenset()

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
            make = planner_registry.classical_planner(self.config.classical).load()
            self.planners[command] = make(command, self.config)
        return self.planners[command]

    def deferred(self, b: BoundStream) -> bool:
        return b.schema.name in self.assumed

    def instantiated(self, b: BoundStream) -> bool:
        """Whether the stream gets optimistic instances (inlined ones need none, and streams
        with ``p_success=0`` are never assumed)."""
        name = b.schema.name
        return name not in self.inline and name not in self.unread and not b.info.never_assumed

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
            wall, cpu = time.perf_counter() - self.started, cpu_seconds() - self.started_cpu
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


def time_limit(run: Run, where: str = "") -> PlanResult:
    return run.result(
        PlanStatus.TIMEOUT,
        f"time limit reached: {'' if run.incumbent else 'no plan within '}"
        f"max_time={run.config.max_time:g} s" + where,
    )


def iteration_limit(run: Run) -> PlanResult:
    if run.store.out_of_time():  # the last iteration may have been cut short by the clock
        return time_limit(run)
    n = run.config.max_iterations
    return run.result(
        PlanStatus.LIMIT,
        f"iteration limit reached: no plan after max_iterations={n} iterations "
        f"({sum(run.store.calls.values())} stream calls)",
    )


def negative_streams(run: Run) -> list[BoundStream]:
    """Non-deferred tests whose certified atoms occur negated (but the ``lazy`` ones, which
    are evaluated for a plan's bindings: :mod:`~llmpas.planning.plan_tests`), streams never
    assumed (``p_success=0``) and eager ones: evaluated on every real binding before a
    search."""
    return [
        b
        for b in run.problem.bound_streams.values()
        if b.schema.name not in run.lazy
        and (
            b.info.never_assumed
            or b.info.eager
            or (
                b.schema.is_test
                and not run.deferred(b)
                and any(a.predicate in run.negative_tests for a in b.schema.certified)
            )
        )
    ]


def object_types(
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


def update_costs(run: Run, opt: list[OptInstance]) -> None:
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


def cpu_seconds() -> float:
    """CPU seconds of this process and its finished children (the Fast Downward searches)."""
    own, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def unsolvable_message(run: Run) -> str:
    records = [*run.store.records.values(), *run.store.fluent_records.values()]
    n = len(records)
    exhausted = sum(r.exhausted for r in records)
    missing = missing_function_value(run.problem)
    return (
        f"{'no cheaper plan' if run.incumbent else 'no plan'}: the classical planner found "
        f"none after {run.iterations} iteration(s); "
        f"{exhausted} of {n} stream instances exhausted" + (f" ({missing})" if missing else "")
    )
