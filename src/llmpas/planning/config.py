"""Planner configuration: one frozen value instead of many keyword arguments."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from llmpas.planning import planner_registry
from llmpas.planning.quality import DEFAULT_QUALITY, QUALITIES, QualityName
from llmpas.planning.result import Algorithm


@dataclass(frozen=True)
class PlannerConfig:
    """How to plan.

    ``defer``: when True, streams whose :class:`~llmpas.language.bindings.StreamInfo` says
    ``deferred`` are assumed satisfiable while planning and left for the executor; when False
    (nothing deferred: every stream computed; ``--no-defer``, formerly called "eager"), every
    stream is evaluated at planning time.

    ``init_identity``: when True, a stream output equal to an init object's value (numbers,
    tuples, arrays: not names) is that object, as in PDDLStream (``llmpas.pddlstream`` sets it);
    off for llmpas's own problems, whose streams' values are new objects (the household's
    placements equal to an init placement would otherwise take that object's facts).

    ``share_placeholders``: when True, instances of a stream evaluated while planning share one
    placeholder per (stream, output, level), as in PDDLStream, so that a ``forall`` ranges over
    fewer objects. Sharing alone is not complete (on the household's blocked-microwave task it
    used up a sampler's outputs on one shared pose and found the goal ``(heated bread)``
    unsolvable), so a task found unsolvable with shared placeholders is planned again from
    scratch with one per instance. Off by default: with the task kept small by the complexity
    limit, the guarded ``forall`` and the binding search, sharing measured no faster on
    ``llmpas bench tamp`` (docs/results/tamp.md), and it changes which plans are found. When
    off, a focused run still shares placeholders from the first optimistic closure that would
    need more than ``max_instances`` instances with one placeholder per instance (streams whose
    outputs feed themselves, such as a belief update applied to its own result, multiply per
    level: ``n`` instances per value give ``n ** max_level``); sharing keeps about ``n`` per
    level, as PDDLStream's shared optimistic objects do.

    Focused planning is adaptive, as PDDLStream's: an instance is assumed only while its
    *complexity* (the highest complexity of its inputs plus, for a stream with outputs, its
    calls + 1) is within a limit that starts at ``max_level`` and rises when a search fails;
    real objects above the limit stay out of the classical task. A test on a new sample is not
    assumed to pass when the same test failed on every earlier output of that sampler (relaxed
    when a search fails and nothing else can be widened). When an evaluated stream plan fails,
    its skeleton is kept: the latest sampler upstream of the failure draws a new value (twice
    at most per failure, and only where the same test passed on another of its values) before
    planning again. With ``algorithm="skeletons"`` (PDDLStream's adaptive), a plan whose
    binding still fails, or whose values fail a test it reads (e.g. a collision test negated in
    an ``Unsafe*`` axiom), is kept as a skeleton and drawn again, with more retries each time
    (up to 4 evaluations; 4 skeletons), one skeleton per iteration before the search (measured
    on PDDLStream's pybullet/tamp -teleport: -n 4 3.9-10 s CPU vs 3.9-45 s without, -n 5 3 of 4
    solved vs 1 of 4; on the 2-D packed family 2.4x slower: docs/pddlstream.md).

    ``lazy_tests`` (focused planning): a test whose predicate is read negated (a collision
    test in an ``Unsafe*`` axiom) is evaluated only on the bindings a plan over real values
    relies on, its negative preimage, as PDDLStream's focused algorithm does
    (:mod:`~llmpas.planning.plan_tests`); when False (the default), on every real binding
    before each search. On for PDDLStream's API (:mod:`llmpas.pddlstream`, whose scripts
    expect PDDLStream's semantics); off for the worlds' sessions: on the PyBullet world at a
    site (tests/worlds/ros2/test_site_run.py) a plan accepted with lazy tests met an anomaly in
    execution that eager evaluation avoids, not yet understood (docs/pddlstream.md).

    Limits. *Counted* limits make the verdict a function of the problem and the config only;
    reaching one ends planning with status ``limit`` and a message naming it:

    - ``max_iterations``: rounds of the planning loop (focused: optimistic searches, each
      followed by the evaluation of the streams its plan relies on; incremental: levels).
    - ``max_stream_calls``: stream calls in all (None: unbounded).
    - ``max_empty_samples``: how many ``None`` ("nothing this time") a sampler may yield in a row
      within one call before the call gives up without an output (the instance stays usable).
      None: it may go on until ``max_time``, so the outcome depends on the machine's speed.
    - ``max_level``: how deep stream outputs may feed other streams in one optimistic pass.
    - ``max_instances``: optimistic stream instances in one closure; beyond it with one
      placeholder per instance the closure is built again with shared placeholders (above),
      and beyond it with shared ones planning stops with status ``limit``. No plan found over
      placeholders shared so is a ``limit`` too, not ``unsolvable`` (sharing is not complete).

    Fast Downward has no expansion or state limit (its engines offer only a cost ``bound`` and a
    ``max_time``), so a classical search runs until it finds a plan or exhausts its finite state
    space, and its answer depends only on its task. The translator's invariant synthesis is
    bounded by its candidate count (100000), not by time.

    *Time and memory* limits are safety nets: ``max_time`` (whole call, wall clock),
    ``search_time`` (wall and CPU clock of each Fast Downward call, at most what is left of
    ``max_time``) and ``memory_mb``. When one fires the status is ``timeout`` (or ``error`` for
    memory), never ``unsolvable``: a verdict that depends on the machine's load.

    *Plan quality* (``quality``, a name in :data:`~llmpas.planning.quality.QUALITIES`; ``llmpas
    plan --quality``):

    - ``fast``: a cost-blind greedy search; the first plan whose streams succeed is returned.
    - ``anytime``: the same first plan, then searches bounded by the incumbent's cost (weighted
      A* with w = 5, 3, 2, 1, then A* on h^max); each cheaper plan has its streams evaluated and
      is replayed before it replaces the incumbent, and is logged and listed in
      :attr:`~llmpas.planning.result.PlanResult.improvements` with its time and cost. After
      each new incumbent, the searches first assume streams only on real values (the quality's
      ``improve_depth``), and go back to ``max_level`` once nothing cheaper is found. It stops
      when ``patience`` iterations in a row bring no cheaper plan, when no cheaper plan exists
      even optimistically, or at a limit (``max_time``, ``max_iterations``, ``max_stream_calls``):
      the incumbent is then returned as solved, the limit named in the message.
    - ``optimal``: A* on h^max in every search; once a plan is realised, A* bounded by its cost
      searches again with the real values (first on real values only, as ``anytime``) until
      nothing cheaper is found: the cheapest plan
      for the samples drawn, not over the continuous space.

    The default is ``fast``, from one run of ``llmpas bench tamp --modes computed --qualities
    fast anytime optimal`` (pds-tamp2d, mirror and packed, N = 1..8, one seed, 30 s wall per
    trial on a loaded machine; docs/results/tamp.md): per instance, against ``fast``'s plan,
    ``optimal`` cost 0.92x (median; 0.59x-1.08x) for 2.3x the CPU (0.2x-38x), and solved 12 of
    its 14 trials (mirror N = 6 and packed N = 8 timed out; ``fast`` solved all 16);
    ``anytime`` cost 0.89x (0.59x-1.0x) for 20x the CPU (it improves until its patience or the
    time limit). Plans that may be replanned often must come quickly and surely: ``fast``.
    ``search`` (a Fast Downward search string) replaces the quality's first search.

    ``algorithm`` names a planning algorithm and ``classical`` the classical planner every
    search runs on, both in :mod:`~llmpas.planning.planner_registry` (``llmpas plan --algorithm``,
    ``--classical``).

    :attr:`deterministic` holds when every counted limit is set; :meth:`validation` is the preset
    for deciding whether goals can be planned (the closed loop's validator), where the same
    inputs must give the same verdict on any machine and under any load.
    """

    algorithm: Algorithm = planner_registry.DEFAULT_ALGORITHM
    defer: bool = True
    max_time: float = 60.0
    max_iterations: int = 200
    max_level: int = 4  # how deep stream outputs may feed other streams in one optimistic pass
    search_time: float = 30.0  # per classical-planner call
    memory_mb: int = 4096
    seed: int = 0
    share_placeholders: bool = False
    init_identity: bool = False  # a stream output equal to an init object's value is that object
    lazy_tests: bool = False  # focused: tests read negated evaluated for a plan's bindings only
    search: str | None = None  # a Fast Downward search string (None: the quality's)
    quality: QualityName = DEFAULT_QUALITY
    patience: int = 10  # anytime: iterations without a cheaper plan before it stops
    max_stream_calls: int | None = None
    max_empty_samples: int | None = None
    max_instances: int = 50_000  # optimistic stream instances in one closure
    classical: str = planner_registry.DEFAULT_CLASSICAL

    def __post_init__(self) -> None:
        planner_registry.algorithm(self.algorithm)  # ValueError naming the choices
        planner_registry.classical_planner(self.classical)
        if not (self.max_time > 0 and self.search_time > 0):  # NaN fails too
            raise ValueError("max_time and search_time must be > 0")
        if not (math.isfinite(self.max_time) and math.isfinite(self.search_time)):
            raise ValueError("max_time and search_time must be finite (they are safety nets)")
        if min(self.max_iterations, self.max_level, self.patience, self.max_instances) < 1:
            raise ValueError("max_iterations, max_level, patience and max_instances must be >= 1")
        if self.quality not in QUALITIES:
            raise ValueError(f"quality must be one of {', '.join(QUALITIES)}, got {self.quality!r}")
        if self.memory_mb < 64:
            raise ValueError(f"memory_mb must be >= 64, got {self.memory_mb}")
        for name in ("max_stream_calls", "max_empty_samples"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or value < 1):
                raise ValueError(f"{name} must be >= 1 or None, got {value!r}")

    @property
    def deterministic(self) -> bool:
        """Whether every counted limit is set, so that only a safety net (reported as
        ``timeout``) can make the verdict depend on the machine's speed."""
        return self.max_stream_calls is not None and self.max_empty_samples is not None

    @classmethod
    def validation(cls, **overrides: Any) -> PlannerConfig:
        """The preset for validating goals: counted limits decide the verdict, and the time
        limits are generous safety nets (10 min per call, 5 min per Fast Downward call) meant
        never to fire; ``overrides`` replace any field (e.g. ``defer``, ``seed``).

        The counts are far above what the household's plans use (76 plans of its scenarios and
        recorded rounds, ``tests/test_system.py`` and ``tests/worlds/household``: at most 3
        iterations, 41 stream calls and 3.8 s), so that what was planned within 60 s there is
        planned within the counts, on any machine."""
        base = cls(
            max_time=600.0,
            search_time=300.0,
            max_iterations=50,
            max_stream_calls=2000,
            max_empty_samples=100,
        )
        return dataclasses.replace(base, **overrides)
