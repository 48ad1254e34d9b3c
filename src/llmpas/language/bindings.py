"""Python implementations of streams, bound by name, normalised to one shape.

Users bind a stream name to one of

- a conditional sampler: a generator (or any callable returning an iterable) of output tuples;
- a function returning one output tuple, or ``None`` when there is none;
- a test returning a bool (streams with no ``:outputs``);
- a cost function returning a number (``:function`` declarations).

``sampler``/``function``/``test``/``cost`` wrap a callable with its :class:`StreamInfo`; a bare
callable is wrapped by what its declaration says and what it returns.
"""

from __future__ import annotations

import inspect
import math
import numbers
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from llmpas.language.language_errors import BindingError
from llmpas.language.logic import Atom
from llmpas.language.streams import FunctionSchema, StreamSchema, StreamSpec


class Kind(Enum):
    AUTO = "auto"
    SAMPLER = "sampler"
    FUNCTION = "function"
    TEST = "test"
    COST = "cost"


@dataclass(frozen=True)
class StreamInfo:
    """Per-stream planning information.

    ``deferred``: assumed satisfiable while planning; evaluated by the executor right before the
    action that needs it (PDDLStream's ``defer_fn``). ``overhead`` (expected cost of one call)
    and ``p_success`` choose which stream instance to evaluate when several could produce a fact
    an optimistic plan relies on: the one with the lowest ``overhead / p_success`` (after the
    shallowest). ``p_success=0`` (as in PDDLStream, an infinite expected cost) means the stream
    is never assumed: it gets no placeholder outputs, and each of its instances on real inputs
    is called once, before the next search, instead. ``eager`` (PDDLStream's ``eager``): each
    instance on real inputs is called before the next search, and the stream is still assumed
    on inputs not computed yet (unless ``p_success=0``). ``max_outputs``
    bounds how many outputs one stream instance may produce during planning. ``opt_fn``
    (``:function`` only, PDDLStream's ``opt_fn``) gives a cost's optimistic value while some of
    its inputs are not computed yet: it gets the inputs' values, ``None`` for those not computed,
    and returns a lower bound of the cost (default: 1).
    """

    deferred: bool = False
    overhead: float = 1.0
    p_success: float = 1.0
    max_outputs: int = 10
    opt_fn: Callable[..., float] | None = None
    eager: bool = False

    @property
    def expected_cost(self) -> float:
        return self.overhead / self.p_success if self.p_success > 0 else math.inf

    @property
    def never_assumed(self) -> bool:
        return self.p_success == 0

    def __post_init__(self) -> None:
        if not 0.0 <= self.p_success <= 1.0:
            raise ValueError(f"p_success must be in [0, 1], got {self.p_success}")
        if self.overhead < 0:
            raise ValueError(f"overhead must be >= 0, got {self.overhead}")
        if self.max_outputs < 1:
            raise ValueError(f"max_outputs must be >= 1, got {self.max_outputs}")
        if self.deferred and self.eager:
            raise ValueError("a stream cannot be both deferred and eager")
        if self.deferred and self.never_assumed:
            raise ValueError("a deferred stream is assumed while planning: p_success must be > 0")
        if self.opt_fn is not None and not callable(self.opt_fn):
            raise ValueError(f"opt_fn must be callable, got {type(self.opt_fn).__name__}")


@dataclass(frozen=True)
class Facts:
    """Facts a stream call reports beyond what its ``:certified`` says (PDDLStream's
    ``WildOutput(facts=...)``): tuples ``(predicate, value, ...)``. A sampler (or a test given as
    a generator) may yield one among its output tuples; the planner takes the facts as true from
    then on, as it takes certified facts (see :meth:`BoundStream.items`)."""

    facts: tuple[tuple[Any, ...], ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "facts", tuple(tuple(f) for f in self.facts))


@dataclass(frozen=True)
class Implementation:
    fn: Callable[..., Any]
    kind: Kind = Kind.AUTO
    info: StreamInfo = field(default_factory=StreamInfo)


def sampler(fn: Callable[..., Iterable[Any]], **info: Any) -> Implementation:
    return Implementation(fn, Kind.SAMPLER, StreamInfo(**info))


def function(fn: Callable[..., Any], **info: Any) -> Implementation:
    return Implementation(fn, Kind.FUNCTION, StreamInfo(**info))


def test(fn: Callable[..., bool], **info: Any) -> Implementation:
    return Implementation(fn, Kind.TEST, StreamInfo(**info))


test.__test__ = False  # type: ignore[attr-defined]  # not a pytest test


def cost(fn: Callable[..., float], **info: Any) -> Implementation:
    """A ``:function``'s implementation; ``opt_fn=`` gives its optimistic value."""
    return Implementation(fn, Kind.COST, StreamInfo(**info))


@dataclass(frozen=True)
class BoundStream:
    """A stream schema with its normalised implementation: ``outputs(values)`` yields tuples."""

    schema: StreamSchema
    impl: Implementation

    @property
    def info(self) -> StreamInfo:
        return self.impl.info

    def fluent_arguments(
        self, facts: Iterable[Atom], values: Mapping[str, Any]
    ) -> list[tuple[Any, ...]]:
        """What a stream with ``:fluents`` gets as ``fluents`` for these facts, as PDDLStream
        gives them: tuples ``(predicate, value, ...)`` of the objects' Python values (an
        object without one stands for itself: its name), sorted by fact."""
        return [(a.predicate, *(values.get(x, x) for x in a.args)) for a in sorted(facts)]

    def outputs(
        self, inputs: tuple[Any, ...], fluents: Iterable[Any] = ()
    ) -> Iterator[tuple[Any, ...]]:
        return (out for out in self.samples(inputs, fluents) if out is not None)

    def samples(
        self, inputs: tuple[Any, ...], fluents: Iterable[Any] = ()
    ) -> Iterator[tuple[Any, ...] | None]:
        """Like :meth:`outputs`, but a sampler's ``None`` ("nothing this time") is passed on, so
        that a caller can check its deadline between values."""
        return (x for x in self.items(inputs, fluents) if not isinstance(x, Facts))

    def items(
        self, inputs: tuple[Any, ...], fluents: Iterable[Any] = ()
    ) -> Iterator[tuple[Any, ...] | Facts | None]:
        """Like :meth:`samples`, with the :class:`Facts` the implementation reports passed on.

        A test answers with a bool; implemented as a function or a sampler (as PDDLStream's
        test streams may be), also with an empty output tuple (passed), or an iterable of them,
        None and :class:`Facts` (the first output tuple: passed; the end: failed)."""
        kwargs = {"fluents": list(fluents)} if self.schema.fluents else {}
        result = self.impl.fn(*inputs, **kwargs)
        if self.schema.is_test:
            yield from self._verdict(result)
            return
        yield from self._normalise(result)

    def _verdict(self, result: Any) -> Iterator[tuple[()] | Facts | None]:
        if result is None or isinstance(result, bool | np.bool_ | int):
            if result:
                yield ()
            return
        if self.impl.kind not in (Kind.SAMPLER, Kind.FUNCTION):
            raise BindingError(
                f"test stream {self.schema.name!r} returned {type(result).__name__}, not bool"
            )
        # implemented as a function or a sampler (PDDLStream's from_fn, from_list_fn, ...)
        items = (result,) if isinstance(result, tuple | Facts) else result
        if isinstance(items, str | bytes) or not isinstance(items, Iterable):
            raise BindingError(
                f"test stream {self.schema.name!r} returned {type(result).__name__}, not bool"
            )
        for item in items:
            if item is None or isinstance(item, Facts):
                yield item
                continue
            yield self._check(item)
            return

    def _normalise(self, result: Any) -> Iterator[tuple[Any, ...] | Facts | None]:
        kind = self.impl.kind
        if result is None:
            return
        if kind is Kind.FUNCTION or (kind is Kind.AUTO and isinstance(result, tuple)):
            yield self._check(result)
            return
        if isinstance(result, str | bytes) or not isinstance(result, Iterable):
            raise BindingError(
                f"stream {self.schema.name!r} returned {type(result).__name__}; expected a tuple "
                "of outputs, None, or an iterable of tuples"
            )
        for item in result:
            # a sampler may yield None for "no output this time", and Facts
            yield item if item is None or isinstance(item, Facts) else self._check(item)

    def _check(self, item: Any) -> tuple[Any, ...]:
        n = len(self.schema.outputs)
        if not isinstance(item, tuple | list) or len(item) != n:
            raise BindingError(
                f"stream {self.schema.name!r} produced {item!r}; expected a tuple of {n} "
                f"output(s) {self.schema.outputs}"
            )
        return tuple(item)


@dataclass(frozen=True)
class BoundFunction:
    schema: FunctionSchema
    impl: Implementation

    def value(self, inputs: tuple[Any, ...]) -> float:
        return self._checked(self.impl.fn(*inputs), "")

    def optimistic(self, inputs: tuple[Any, ...], default: float) -> float:
        """The cost while some inputs (``None``) are not computed yet."""
        opt = self.impl.info.opt_fn
        return default if opt is None else self._checked(opt(*inputs), "'s opt_fn")

    def _checked(self, v: Any, what: str) -> float:
        name = f"function {self.schema.name!r}{what}"
        if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real):
            raise BindingError(f"{name} returned {v!r}, not a number")
        x = float(v)
        if not (x >= 0 and math.isfinite(x)):
            raise BindingError(f"{name} returned {v}, costs must be finite and >= 0")
        return x


RULE_INFO = StreamInfo(overhead=0.0)


def _always(*_: Any) -> bool:
    return True


@dataclass(frozen=True)
class _Complement:
    """An external predicate's implementation, as the test of its complement ``not__P``."""

    fn: Callable[..., Any]
    name: str

    def __call__(self, *args: Any) -> bool:
        result = self.fn(*args)
        if not isinstance(result, bool | np.bool_ | int) and result is not None:
            raise BindingError(
                f"predicate {self.name!r} returned {type(result).__name__}, not bool"
            )
        return not result


def _as_impl(obj: Any, name: str) -> Implementation:
    if isinstance(obj, Implementation):
        return obj
    if callable(obj):
        kind = Kind.SAMPLER if inspect.isgeneratorfunction(obj) else Kind.AUTO
        return Implementation(obj, kind)
    raise BindingError(f"implementation of {name!r} is {type(obj).__name__}, not callable")


def bind(
    spec: StreamSpec,
    implementations: Mapping[str, Any],
    info: Mapping[str, StreamInfo] | None = None,
) -> tuple[dict[str, BoundStream], dict[str, BoundFunction]]:
    """Match declarations to implementations by name; every one must have its partner."""
    impls = {k.lower(): v for k, v in implementations.items()}
    declared = {s.name for s in spec.streams if not s.is_rule} | {f.name for f in spec.functions}
    missing = sorted(declared - impls.keys())
    if missing:
        raise BindingError(
            f"{spec.filename}: stream {missing[0]!r} is declared but has no Python implementation"
        )
    extra = sorted(impls.keys() - declared)
    if extra:
        raise BindingError(
            f"implementation {extra[0]!r} is given but {spec.filename} declares no such stream"
        )
    overrides = {k.lower(): v for k, v in (info or {}).items()}
    unknown = sorted(overrides.keys() - declared)
    if unknown:
        raise BindingError(
            f"stream info for {unknown[0]!r}: {spec.filename} declares no such stream"
        )
    streams: dict[str, BoundStream] = {}
    for s in spec.streams:
        if s.is_rule:  # an axiom: always holds, costs nothing
            streams[s.name] = BoundStream(s, Implementation(_always, Kind.TEST, RULE_INFO))
            continue
        impl = _as_impl(impls[s.name], s.name)
        if s.is_test and not isinstance(impls[s.name], Implementation):
            impl = Implementation(impl.fn, Kind.AUTO, impl.info)  # a bare callable: a bool
        if s.is_predicate:
            impl = Implementation(_Complement(impl.fn, s.name), Kind.TEST, impl.info)
        if impl.kind is Kind.COST:
            raise BindingError(f"stream {s.name!r} is bound to a cost function")
        if s.name in overrides:
            impl = Implementation(impl.fn, impl.kind, overrides[s.name])
        if impl.info.opt_fn is not None:
            raise BindingError(f"stream {s.name!r}: opt_fn is for ':function' costs only")
        streams[s.name] = BoundStream(s, impl)
    functions = {f.name: BoundFunction(f, _as_impl(impls[f.name], f.name)) for f in spec.functions}
    return streams, functions
