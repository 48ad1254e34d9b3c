"""Stream instances during one planning run: what was evaluated, and what is only assumed.

:class:`StreamStore` holds the *real* facts (init plus what evaluated streams certified) and one
record per stream instance (a stream applied to concrete inputs). :func:`optimistic_instances`
computes the optimistic closure: every instance that could be applied, with placeholder outputs
``#oN`` standing for values not computed yet.

Placeholders of streams evaluated while planning are *shared*, as in PDDLStream: every instance
of one stream gets the same placeholder per output and level (level = 1 + the highest level of
its inputs, real objects being level 0). The number of objects, and so the grounded task, stays
small; a plan over shared placeholders is only optimistic and is planned again once the streams
it relies on have produced real values. Placeholders of deferred streams stay unique per
instance: they reach the executor, which must tell them apart.
"""

from __future__ import annotations

import functools
import itertools
import logging
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from llmpas.language.bindings import BoundStream, Facts, Kind
from llmpas.language.domain import Domain
from llmpas.language.logic import (
    And,
    Atom,
    Exists,
    Forall,
    Formula,
    Not,
    Or,
    Substitution,
)
from llmpas.language.problem import Problem, ValueNamer, known_predicates, value_key
from llmpas.language.semantics import Evaluator, State, Universe, nnf
from llmpas.planning.externals import external_rewrite
from llmpas.planning.fluents import CONTEXT_OBJECT

log = logging.getLogger(__name__)

OPTIMISTIC_PREFIX = "#o"
_END = object()  # sentinel: a stream's iterator is exhausted
_IDLE = object()  # sentinel: a sampler yielded only None (up to its limit or the deadline)


def is_optimistic(name: str) -> bool:
    return name.startswith(OPTIMISTIC_PREFIX)


class StreamFailure(RuntimeError):
    """A user stream raised an exception; the message names the stream instance."""


class LimitReached(RuntimeError):
    """A counted limit of the planner was reached; the message names it."""


@dataclass
class Record:
    """The evaluation history of one stream instance (mutable, private to a planning run)."""

    bound: BoundStream
    inputs: tuple[str, ...]
    iterator: Iterator[tuple[Any, ...] | Facts | None] | None = None
    calls: int = 0
    outputs: list[tuple[str, ...]] = field(default_factory=list)
    exhausted: bool = False
    enabled: bool = True  # focused: disabled after a call until a search fails
    #: a fluent stream's context: the fluent facts it is called with (None: not a fluent record)
    fluents: frozenset[Atom] | None = None


@dataclass(frozen=True)
class OptInstance:
    """An instance in the optimistic closure: inputs may themselves be placeholders.

    ``step``: for a fluent stream, the plan step whose state it is evaluated in (a copy of the
    closure's instance per step; None in the closure)."""

    stream: BoundStream
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    certified: tuple[Atom, ...]
    level: int
    step: int | None = None

    @property
    def key(self) -> tuple[str, tuple[str, ...]]:
        return self.stream.schema.name, self.inputs

    @property
    def domain(self) -> tuple[Atom, ...]:
        """The stream's domain facts on these inputs (what the instance needs to apply)."""
        schema = self.stream.schema
        sub = Substitution(dict(zip(schema.inputs, self.inputs, strict=True)))
        return tuple(sub.atom(a) for a in schema.domain)


def rejected_predicate(pred: str) -> str:
    return f"rejected__{pred}"


def join(atoms: tuple[Atom, ...], state: State) -> Iterator[dict[str, str]]:
    """Bindings of the variables of a conjunction of positive atoms in ``state``."""
    universe = Universe(_JOIN_DOMAIN, {})
    yield from Evaluator(universe, state).solve(And(atoms), {}, {})


class StreamStore:
    """Real facts, object values and stream-instance records of one planning run.

    ``max_calls`` bounds the stream calls in all (reaching it raises :class:`LimitReached`
    before the call); ``max_empty`` bounds the ``None`` a sampler may yield in a row within one
    call (None: until the deadline)."""

    def __init__(
        self,
        problem: Problem,
        deadline: float,
        max_calls: int | None = None,
        max_empty: int | None = None,
        init_identity: bool = False,
    ) -> None:
        self.problem = problem
        self.deadline = deadline
        self.max_calls = max_calls
        self.max_empty = max_empty
        self.facts: set[Atom] = set(problem.init)
        self.rejected: set[Atom] = set()
        # init_identity: a stream output equal to an init object's value is that object, as in
        # PDDLStream (PlannerConfig.init_identity)
        known = problem.objects if init_identity else None
        self.namer = ValueNamer(taken=problem.all_objects, prefix="s", known=known)
        self.values: dict[str, Any] = dict(problem.objects)
        self.records: dict[tuple[str, tuple[str, ...]], Record] = {}
        self.calls: Counter[str] = Counter()
        self.time = 0.0
        #: complexity of each real object produced here (others: 0), see :meth:`complexity_of`
        self.complexity: dict[str, int] = {}
        self._given = frozenset(problem.all_objects)
        #: fluent streams: records per (stream, inputs, context), the real facts they certified
        #: with the contexts they hold in, and the active blocks (see :mod:`.fluents`)
        self.fluent_records: dict[tuple[str, tuple[str, ...], frozenset[Atom]], Record] = {}
        self.fluent_facts: dict[Atom, set[frozenset[Atom]]] = {}
        #: blocks: in every state with the context's facts, until a search fails (lifted then);
        #: exact blocks (the instance is exhausted there): in states with exactly those facts,
        #: for good. Both map (stream, inputs, context) to the context's object ``#cN``.
        self.blocks: dict[tuple[str, tuple[str, ...], frozenset[Atom]], str] = {}
        self.exact: dict[tuple[str, tuple[str, ...], frozenset[Atom]], str] = {}
        self._context_names: dict[tuple[str, tuple[str, ...], frozenset[Atom]], str] = {}
        self._contexts = itertools.count(1)
        #: facts streams reported beyond their certified ones (:class:`Facts`, PDDLStream's
        #: WildOutput); also in ``facts``
        self.wild: set[Atom] = set()
        self._arity = known_predicates(problem.domain, problem.streams)
        self._unknown: set[str] = set()

    def input_complexity(self, inputs: tuple[str, ...]) -> int:
        """The highest complexity of real objects among ``inputs`` (placeholders: see
        :func:`optimistic_instances`)."""
        return max((self.complexity.get(x, 0) for x in inputs), default=0)

    def complexity_of(self, rec: Record) -> int:
        """PDDLStream's complexity of the instance's next result: the highest complexity of its
        inputs plus, for a stream with outputs, its calls so far plus one (a test adds
        nothing). An object produced by that call has this complexity."""
        return self.input_complexity(rec.inputs) + _call_weight(rec.bound, rec.calls)

    def above(self, limit: int) -> dict[str, int]:
        """The real objects whose complexity exceeds ``limit``, with their complexity."""
        return {x: c for x, c in self.complexity.items() if c > limit}

    def record(self, bound: BoundStream, inputs: tuple[str, ...]) -> Record:
        key = (bound.schema.name, inputs)
        if key not in self.records:
            self.records[key] = Record(bound, inputs)
        return self.records[key]

    def fluent_record(
        self, bound: BoundStream, inputs: tuple[str, ...], fluents: frozenset[Atom]
    ) -> Record:
        """The record of a fluent stream's instance in one context."""
        key = (bound.schema.name, inputs, fluents)
        if key not in self.fluent_records:
            self.fluent_records[key] = Record(bound, inputs, fluents=fluents)
        return self.fluent_records[key]

    def block(self, rec: Record) -> None:
        """Block a fluent record that failed in its context (until :meth:`unblock`; an
        exhausted one also exactly there, for good)."""
        assert rec.fluents is not None
        key = (rec.bound.schema.name, rec.inputs, rec.fluents)
        if key not in self._context_names:
            self._context_names[key] = f"{CONTEXT_OBJECT}{next(self._contexts)}"
        self.blocks[key] = self._context_names[key]
        if rec.exhausted:
            self.exact[key] = self._context_names[key]

    def unblock(self) -> bool:
        """Lift every block but the exact ones; True when there was any."""
        had = bool(self.blocks)
        self.blocks.clear()
        return had

    def holds_in(self, fact: Atom, fluents: frozenset[Atom]) -> bool:
        """Whether a fluent stream certified ``fact`` in the context ``fluents``."""
        return fluents in self.fluent_facts.get(fact, ())

    def call(self, rec: Record) -> tuple[str, ...] | None:
        """One more output of the instance (names of new objects), or None when it has none."""
        if rec.exhausted:
            return None
        if self.max_calls is not None and self.calls.total() >= self.max_calls:
            raise LimitReached(
                f"stream-call limit reached: max_stream_calls={self.max_calls} calls made, "
                f"the next would be {rec.bound.schema.name}({' '.join(rec.inputs)})"
            )
        complexity = self.complexity_of(rec)  # of what this call produces
        start = time.perf_counter()
        try:
            out = self._next(rec)
        finally:
            self.time += time.perf_counter() - start
            self.calls[rec.bound.schema.name] += 1
            rec.calls += 1
        schema = rec.bound.schema
        if out is _IDLE:  # the sampler yielded only None (limit or deadline): not exhausted
            return None
        if out is None:
            rec.exhausted = True
            if schema.is_test and rec.fluents is None:
                sub = Substitution(dict(zip(schema.inputs, rec.inputs, strict=True)))
                self.rejected |= {
                    Atom(rejected_predicate(a.predicate), sub.atom(a).args)
                    for a in schema.certified
                }
            return None
        names = tuple(self._name(v) for v in out)
        for n in names:
            if n not in self._given:
                self.complexity[n] = min(self.complexity.get(n, complexity), complexity)
        rec.outputs.append(names)
        sub = Substitution(
            dict(zip(schema.inputs + schema.outputs, rec.inputs + names, strict=True))
        )
        if rec.fluents is None:
            self.facts |= {sub.atom(a) for a in schema.certified}
        else:
            for a in schema.certified:
                self.fluent_facts.setdefault(sub.atom(a), set()).add(rec.fluents)
        single = rec.bound.impl.kind is Kind.FUNCTION  # a function has one output at most
        if schema.is_test or single or rec.calls >= rec.bound.info.max_outputs:
            rec.exhausted = True
        return names

    def _next(self, rec: Record) -> Any:
        """The next output tuple; None when exhausted; ``_IDLE`` when the sampler yielded only
        ``None`` ("nothing this time"), ``max_empty`` times in a row or until the deadline
        (checked on every value)."""
        if rec.iterator is None:
            values = tuple(self.values.get(n, n) for n in rec.inputs)
            facts = self._fluents(rec.bound) if rec.fluents is None else rec.fluents
            fluents = rec.bound.fluent_arguments(facts, self.values)
            rec.iterator = rec.bound.items(values, fluents)
        iterator = rec.iterator
        empty = 0
        reported = False
        while True:
            item = self._guard(rec, lambda: next(iterator, _END))
            if item is _END:
                return None
            if isinstance(item, Facts):
                self._guard(rec, functools.partial(self._report, rec, item))
                reported = True
                continue
            if item is not None:
                return item
            if reported:  # new facts but no output this time: progress, not exhausted
                return _IDLE
            empty += 1
            if (self.max_empty is not None and empty >= self.max_empty) or self.out_of_time():
                return _IDLE

    def _guard(self, rec: Record, fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        except Exception as e:  # a user's stream failed: say which instance
            args = " ".join(rec.inputs)
            raise StreamFailure(
                f"stream {rec.bound.schema.name}({args}) raised {type(e).__name__}: {e}"
            ) from e

    def _report(self, rec: Record, reported: Facts) -> None:
        """Take the facts a call reported beyond its certified ones as true (PDDLStream's
        WildOutput): a value equal to one of the instance's inputs is that input, another is
        named as an output would be (and has the complexity of this call's outputs)."""
        if rec.fluents is not None:
            raise ValueError("a stream with :fluents reported facts beyond its certified ones")
        inputs = {value_key(self.values.get(n, n)): n for n in rec.inputs}
        complexity = self.complexity_of(rec)
        derived = self.problem.domain.derived_names
        for fact in reported.facts:
            if not fact or not isinstance(fact[0], str):
                raise ValueError(f"reported fact {fact!r} does not start with a predicate name")
            pred, args = fact[0].lower(), fact[1:]
            arity = self._arity.get(pred)
            if pred in derived or pred == "=":
                raise ValueError(f"reported fact {fact!r}: '{pred}' cannot be given as a fact")
            if arity is None:
                if pred not in self._unknown:
                    self._unknown.add(pred)
                    log.warning(
                        "stream %s reported facts of '%s', which neither the domain nor a "
                        "stream uses: ignored",
                        rec.bound.schema.name,
                        pred,
                    )
                continue
            if arity != len(args):
                raise ValueError(
                    f"reported fact {fact!r}: '{pred}' takes {arity} arguments, given {len(args)}"
                )
            names = []
            for v in args:
                n = inputs.get(value_key(v)) or self._name(v)
                if n not in self._given:
                    self.complexity[n] = min(self.complexity.get(n, complexity), complexity)
                names.append(n)
            atom = Atom(pred, tuple(names))
            self.facts.add(atom)
            self.wild.add(atom)

    def _fluents(self, bound: BoundStream) -> list[Atom]:
        """The real facts of the stream's ``:fluents`` predicates (none without: the facts are
        not scanned, which on every call would make planning quadratic in the facts)."""
        preds = set(bound.schema.fluents)
        if not preds:
            return []
        return sorted(a for a in self.facts if a.predicate in preds)

    def _name(self, value: Any) -> str:
        name = self.namer.name(value)
        self.values.setdefault(name, value)
        return name

    def out_of_time(self) -> bool:
        return time.perf_counter() > self.deadline


def _call_weight(bound: BoundStream, calls: int) -> int:
    """What one more result adds to complexity: 0 for a stream without outputs (a test), else
    ``calls + 1``: the more an instance was sampled, the later its next sample is assumed."""
    return 0 if not bound.schema.outputs else calls + 1


def negative_test_predicates(problem: Problem) -> set[str]:
    """Predicates certified by test streams that occur negated in the domain or goal."""
    tests = problem.streams.test_predicates
    formulas: list[Formula] = [problem.goal]
    formulas += [a.precondition for a in problem.domain.actions]
    formulas += [d.body for d in problem.domain.derived]
    external = problem.streams.external_predicates
    found: set[str] = set()
    for f in formulas:
        g = nnf(external_rewrite(f, external))
        found |= {a.predicate for a in _negated_atoms(g)} & tests
    return found


def _negated_atoms(f: Formula) -> Iterator[Atom]:
    """Atoms under ``not`` in a formula in negation normal form."""
    match f:
        case Not(Atom() as a):
            yield a
        case And(parts) | Or(parts):
            for p in parts:
                yield from _negated_atoms(p)
        case Exists(_, body) | Forall(_, body):
            yield from _negated_atoms(body)


def evaluate_negative_tests(store: StreamStore, streams: Iterable[BoundStream]) -> None:
    """Evaluate every not-yet-evaluated real binding of the given test streams."""
    state = State(store.facts)
    for bound in streams:
        for env in list(join(bound.schema.domain, state)):
            inputs = tuple(env[v] for v in bound.schema.inputs)
            rec = store.record(bound, inputs)
            if rec.calls == 0:
                store.call(rec)
            if store.out_of_time():
                return


class _Namer:
    """Placeholder names: ``#oN``, one per (stream, output, level) for shared streams."""

    def __init__(self, shared: Callable[[BoundStream], bool]) -> None:
        self.shared = shared
        self.counter = itertools.count(1)
        self.names: dict[tuple[str, int, int], str] = {}

    def outputs(self, bound: BoundStream, level: int) -> tuple[str, ...]:
        n = len(bound.schema.outputs)
        if not self.shared(bound):
            return tuple(self._fresh() for _ in range(n))
        keys = [(bound.schema.name, i, level) for i in range(n)]
        return tuple(self.names.get(k) or self.names.setdefault(k, self._fresh()) for k in keys)

    def _fresh(self) -> str:
        return f"{OPTIMISTIC_PREFIX}{next(self.counter)}"


@dataclass
class Closure:
    """Bounds of one optimistic closure, and what they left out.

    ``complexity_limit``: instances of higher complexity are left out (None: no limit);
    ``pruned`` is the lowest complexity left out (None: nothing was).

    ``evidence``: a test on a placeholder is not assumed to pass when the same test failed on
    at least this many real outputs of the placeholder's producer and passed on none (None:
    always assumed); ``withheld`` counts the tests not assumed."""

    complexity_limit: int | None = None
    evidence: int | None = None
    pruned: int | None = None
    withheld: int = 0

    def prune(self, complexity: int) -> None:
        self.pruned = complexity if self.pruned is None else min(self.pruned, complexity)

    def within(self, store: StreamStore) -> set[Atom]:
        """The real facts naming no object above the complexity limit (any instance on the
        others is above it too, and is counted as left out)."""
        limit = self.complexity_limit
        if limit is None:
            return set(store.facts)
        high = store.above(limit)
        if high:
            self.prune(min(high.values()))
        return {a for a in store.facts if high.keys().isdisjoint(a.args)}

    @property
    def narrowed(self) -> bool:
        """Whether a bound left anything out."""
        return self.pruned is not None or self.withheld > 0


def optimistic_instances(
    store: StreamStore,
    allowed: Callable[[BoundStream], bool],
    max_level: int,
    limit: int = 50_000,
    shared: Callable[[BoundStream], bool] = lambda b: False,
    closure: Closure | None = None,
) -> list[OptInstance]:
    """The optimistic closure of the real facts under the allowed, enabled, non-exhausted
    instances; streams for which ``shared`` holds share their placeholders (module docstring).

    An instance is left out when its level (how many placeholders deep) exceeds ``max_level``,
    or when a bound of ``closure`` says so: its complexity (PDDLStream's: the highest complexity
    of its inputs, real or placeholder, plus the instance's calls + 1 for a stream with outputs)
    exceeds the limit, or it is a test on a placeholder that the evidence says fails."""
    closure = closure or Closure()
    closer = _Closer(store, max_level, _Namer(shared), closure)
    facts = closure.within(store)
    out: list[OptInstance] = []
    streams = [b for b in store.problem.bound_streams.values() if allowed(b)]
    changed = True
    while changed:
        changed = False
        state = State(facts)
        for bound in streams:
            for inst in closer.new_instances(bound, state):
                out.append(inst)
                facts |= set(inst.certified)
                changed = True
                if len(out) > limit:
                    raise LimitReached(
                        f"more than {limit} optimistic stream instances; lower max_level or "
                        "give stream :domain facts that restrict inputs"
                    )
    return out


_Key = tuple[str, tuple[str, ...]]


class _Closer:
    """The bookkeeping of one optimistic closure: per placeholder its level, complexity and
    producers (instance key, output index)."""

    def __init__(self, store: StreamStore, max_level: int, namer: _Namer, closure: Closure):
        self.store = store
        self.max_level = max_level
        self.namer = namer
        self.closure = closure
        self.seen: set[_Key] = set()
        self.level: dict[str, int] = {}
        self.complexity: dict[str, int] = {}
        self.producers: dict[str, list[tuple[_Key, int]]] = {}

    def new_instances(self, bound: BoundStream, state: State) -> Iterator[OptInstance]:
        schema = bound.schema
        store, closure = self.store, self.closure
        for env in list(join(schema.domain, state)):
            inputs = tuple(env[v] for v in schema.inputs)
            key = (schema.name, inputs)
            if key in self.seen:
                continue
            rec = store.records.get(key)
            if rec is not None and (rec.exhausted or not rec.enabled):
                continue
            lvl = 1 + max((self.level.get(i, 0) for i in inputs), default=0)
            if lvl > self.max_level:
                continue
            cost = self._inherited(inputs) + _call_weight(bound, rec.calls if rec else 0)
            if closure.complexity_limit is not None and cost > closure.complexity_limit:
                closure.prune(cost)
                continue
            if not schema.outputs and self._refuted(key):
                self.seen.add(key)
                closure.withheld += 1
                continue
            self.seen.add(key)
            yield self._instance(bound, inputs, lvl, cost)

    def _inherited(self, inputs: tuple[str, ...]) -> int:
        return max(
            (self.complexity.get(i, self.store.complexity.get(i, 0)) for i in inputs), default=0
        )

    def _instance(
        self, bound: BoundStream, inputs: tuple[str, ...], lvl: int, cost: int
    ) -> OptInstance:
        schema = bound.schema
        outputs = self.namer.outputs(bound, lvl)
        for k, o in enumerate(outputs):
            self.level[o] = lvl
            self.complexity[o] = min(self.complexity.get(o, cost), cost)  # shared: the lowest
            self.producers.setdefault(o, []).append(((schema.name, inputs), k))
        sub = Substitution(dict(zip(schema.inputs + schema.outputs, inputs + outputs, strict=True)))
        certified = tuple(sub.atom(a) for a in schema.certified)
        return OptInstance(bound, inputs, outputs, certified, lvl)

    def _refuted(self, key: _Key) -> bool:
        """Whether the evidence says the test ``key`` on one placeholder fails: on the real
        outputs of every producer of that placeholder, the same test failed at least
        ``evidence`` times and never passed."""
        need = self.closure.evidence
        name, inputs = key
        holes = [j for j, x in enumerate(inputs) if is_optimistic(x)]
        if need is None or len(holes) != 1:
            return False
        j = holes[0]
        failed = 0
        for producer, k in self.producers.get(inputs[j], []):
            made = self.store.records.get(producer)
            for out in made.outputs if made is not None else []:
                test = self.store.records.get((name, (*inputs[:j], out[k], *inputs[j + 1 :])))
                if test is None or not test.exhausted:
                    continue  # not evaluated on that output
                if test.outputs:
                    return False  # it passed once
                failed += 1
        return failed >= need


_JOIN_DOMAIN = Domain("join")  # immutable; joins of positive atoms need no types
