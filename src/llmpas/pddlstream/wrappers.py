"""PDDLStream's stream wrappers (``from_gen_fn``, ``from_fn``, ``from_test``, ...) and stream
options (``StreamInfo``, ``FunctionInfo``), mapped onto llmpas's bound implementations.

A wrapper is a :class:`Procedure`: the user's function and how it answers (one output tuple,
a list of them, a generator of them, a bool). :meth:`Procedure.implementation` gives the
:class:`~llmpas.language.bindings.Implementation` llmpas's planner calls. A bare callable in a
``stream_map`` means, as in PDDLStream, a generator of *lists* of output tuples for a
``:stream``, and the function itself for a ``:function`` or a ``:predicate``.
"""

from __future__ import annotations

import enum
import itertools
import logging
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from llmpas.language.bindings import Facts, Implementation, Kind
from llmpas.language.bindings import StreamInfo as NativeInfo

log = logging.getLogger(__name__)

DEBUG = "debug"
SHARED_DEBUG = "shared_debug"


class Shape(enum.Enum):
    """How a wrapped function answers."""

    FN = "fn"  # one output tuple, or None
    LIST_FN = "list_fn"  # a list of output tuples, or None
    GEN = "gen"  # an iterable of output tuples (None: nothing this time)
    LIST_GEN = "list_gen"  # an iterable of lists of output tuples ([]: nothing this time)
    SAMPLER = "sampler"  # one output tuple (or None) per call, called again for more
    TEST = "test"  # a truth value


@dataclass(frozen=True)
class Procedure:
    """A user's function wrapped the way PDDLStream's ``from_*`` says it answers."""

    fn: Callable[..., Any]
    shape: Shape

    def __post_init__(self) -> None:
        if not callable(self.fn):
            raise TypeError(f"from_{self.shape.value}: {self.fn!r} is not callable")

    def implementation(self) -> Implementation:
        if self.shape is Shape.TEST:
            return Implementation(_Truth(self.fn), Kind.TEST)
        if self.shape is Shape.FN:
            return Implementation(_Single(self.fn), Kind.FUNCTION)
        return Implementation(_Outputs(self.fn, self.shape), Kind.SAMPLER)

    def __call__(self, *inputs: Any, **kwargs: Any) -> Iterator[list[tuple[Any, ...]]]:
        """PDDLStream's protocol: a generator of lists of output tuples."""
        if self.shape is Shape.TEST:
            yield [()] if self.fn(*inputs, **kwargs) else []
            return
        for out in _Outputs(self.fn, self.shape)(*inputs, **kwargs):
            yield [] if out is None else [tuple(out)]


@dataclass(frozen=True)
class WildOutput:
    """PDDLStream's answer of one call with facts beyond the certified ones: ``values`` (the
    output tuples) and ``facts`` (tuples ``(predicate, value, ...)``, true from then on).
    ``enumerated=True``: the generator has nothing more. PDDLStream takes one from a
    ``from_list_fn`` function or a generator of lists (a bare callable), and so does llmpas
    (as :class:`~llmpas.language.bindings.Facts` items); ``actions`` is refused, as there."""

    values: Any = ()
    facts: Any = ()
    actions: Any = ()
    enumerated: bool = False
    replan: bool = False

    def __post_init__(self) -> None:
        if self.actions:
            raise TypeError("WildOutput(actions=...) is not supported (nor by PDDLStream)")

    def __iter__(self) -> Iterator[Any]:
        return iter((self.values, self.facts))


def _no_wild(result: Any, shape: Shape) -> Any:
    if isinstance(result, WildOutput):
        raise TypeError(
            f"a from_{shape.value} function returned a WildOutput: PDDLStream takes one only "
            "from from_list_fn or a generator of lists"
        )
    return result


def _batch(result: Any, more: bool = False) -> Iterator[Any]:
    """One list of output tuples, or a WildOutput: its facts first (as :class:`Facts`), then its
    output tuples; with ``more`` (a generator's batch), None when there is no output ("nothing
    this time")."""
    if not isinstance(result, WildOutput):
        yield from result
        return
    facts = list(result.facts or ())
    values = list(result.values or ())
    if facts:
        yield Facts(tuple(tuple(f) for f in facts))
    if not values and more:
        yield None
    yield from values


@dataclass(frozen=True)
class _Single:
    """A ``from_fn`` function: one output tuple, or None."""

    fn: Callable[..., Any]

    def __call__(self, *inputs: Any, **kwargs: Any) -> Any:  # kwargs: fluents
        return _no_wild(self.fn(*inputs, **kwargs), Shape.FN)


@dataclass(frozen=True)
class _Truth:
    fn: Callable[..., Any]

    def __call__(self, *inputs: Any, **kwargs: Any) -> bool:  # kwargs: fluents
        return bool(self.fn(*inputs, **kwargs))


@dataclass(frozen=True)
class _Outputs:
    """A sampler in llmpas's shape: yields output tuples, or None for "nothing this time"."""

    fn: Callable[..., Any]
    shape: Shape

    def __call__(self, *inputs: Any, **kwargs: Any) -> Iterator[Any]:  # kwargs: fluents
        if self.shape is Shape.SAMPLER:
            while True:
                yield _no_wild(self.fn(*inputs, **kwargs), self.shape)
        result = self.fn(*inputs, **kwargs)
        if result is None:
            return
        if self.shape is Shape.LIST_FN:
            yield from _batch(result)
            return
        _no_wild(result, self.shape)
        if self.shape is Shape.FN:
            yield result
        elif self.shape is Shape.GEN:
            yield from (_no_wild(out, self.shape) for out in result)
        else:  # LIST_GEN
            for batch in result:
                if isinstance(batch, WildOutput):
                    yield from _batch(batch, more=True)
                    if batch.enumerated:
                        return
                elif not batch:
                    yield None
                else:
                    yield from batch


def from_fn(fn: Callable[..., Any]) -> Procedure:
    return Procedure(fn, Shape.FN)


def from_list_fn(fn: Callable[..., Any]) -> Procedure:
    return Procedure(fn, Shape.LIST_FN)


def from_gen_fn(fn: Callable[..., Iterable[Any]]) -> Procedure:
    return Procedure(fn, Shape.GEN)


def from_list_gen_fn(fn: Callable[..., Iterable[Any]]) -> Procedure:
    return Procedure(fn, Shape.LIST_GEN)


def from_sampler(fn: Callable[..., Any]) -> Procedure:
    return Procedure(fn, Shape.SAMPLER)


def from_test(fn: Callable[..., Any]) -> Procedure:
    return Procedure(fn, Shape.TEST)


def from_gen(generator: Iterable[Any]) -> Procedure:
    """One generator shared by every call (as PDDLStream's ``from_gen``)."""
    it = iter(generator)
    return from_gen_fn(lambda *_: it)


@dataclass(frozen=True)
class _Constant:
    value: Any

    def __call__(self, *_: Any) -> Any:
        return self.value


@dataclass(frozen=True, eq=False)
class DebugValue:
    """An output of PDDLStream's ``debug`` streams: a new object per call (``index`` counts
    them), equal only to itself, as there."""

    stream: str
    input_values: tuple[Any, ...]
    output_parameter: str
    index: int

    def __repr__(self) -> str:
        return f"@{self.output_parameter.lstrip('?')}{self.index}"


class SharedDebugValue(NamedTuple):
    """An output of PDDLStream's ``shared_debug`` streams: one per stream and output."""

    stream: str
    output_parameter: str

    def __repr__(self) -> str:
        return f"&{self.output_parameter.lstrip('?')}"


@dataclass(frozen=True)
class _Debug:
    """A stream of PDDLStream's debug ``stream_map``: one call, one output tuple of debug values
    (a test passes)."""

    stream: str
    outputs: tuple[str, ...]
    shared: bool
    counter: Iterator[int] = field(default_factory=itertools.count, compare=False)

    def __call__(self, *inputs: Any, **_: Any) -> tuple[Any, ...]:  # _: fluents
        if self.shared:
            return tuple(SharedDebugValue(self.stream, o) for o in self.outputs)
        return tuple(DebugValue(self.stream, inputs, o, next(self.counter)) for o in self.outputs)


def debug_stream(stream: str, outputs: tuple[str, ...], shared: bool) -> Procedure:
    return from_fn(_Debug(stream, outputs, shared))


def fn_from_constant(value: Any) -> Callable[..., Any]:
    return _Constant(value)


def from_constant(value: Any) -> Procedure:
    return from_fn(fn_from_constant(value))


@dataclass(frozen=True)
class _Negated:
    test: Callable[..., Any]

    def __call__(self, *inputs: Any) -> bool:
        return not self.test(*inputs)


def negate_test(test: Callable[..., Any]) -> Callable[..., bool]:
    return _Negated(test)


def _nothing(*_: Any) -> Iterator[Any]:
    return iter(())


universe_test = from_test(fn_from_constant(True))
empty_test = from_test(fn_from_constant(False))


def empty_gen() -> Procedure:
    return from_gen_fn(_nothing)


def outputs_from_boolean(value: Any) -> tuple[tuple[()], ...]:
    return ((),) if value else ()


def accelerate_list_gen_fn(list_gen_fn: Callable[..., Any], *_: Any, **__: Any) -> Any:
    """PDDLStream batches outputs; here each output is taken as it comes."""
    return list_gen_fn


# ------------------------------------------------------------------------------------ options


def never_defer(*_: Any, **__: Any) -> bool:
    return False


def defer_unique(*_: Any, **__: Any) -> bool:
    return True


def defer_shared(*_: Any, **__: Any) -> bool:
    return True


def get_defer_any_unbound(unique: bool = False) -> Callable[..., bool]:
    return defer_unique if unique else defer_shared


def get_defer_all_unbound(inputs: str = "", unique: bool = False) -> Callable[..., bool]:
    return defer_unique if unique else defer_shared


class PartialInputs(NamedTuple):
    """PDDLStream's optimistic-output generator; llmpas makes its own placeholders."""

    inputs: str = ""
    unique: bool = False
    num: int = 1


# what each option does here; options not listed are accepted and said to be ignored
_USED = {
    "p_success": "the probability of success (llmpas p_success)",
    "overhead": "the expected cost of one call (llmpas overhead)",
    "eager": "eager=True: called on real inputs before each search (llmpas eager)",
    "opt_fn": "a cost's optimistic value (llmpas opt_fn)",
}
_SILENT = {"verbose", "defer_fn", "opt_gen_fn"}  # their default values mean nothing here
_WHY = {
    "defer_fn": "every stream a plan needs is evaluated before solve returns it",
    "opt_gen_fn": "llmpas makes its own placeholder outputs",
}


OPT_DEFAULT = 1.0  # llmpas's optimistic cost of a function whose inputs are not computed yet


@dataclass(frozen=True)
class _Optimistic:
    """A ``FunctionInfo(opt_fn)``: llmpas calls it with None for inputs not computed yet, where
    PDDLStream passes optimistic objects (with ``.values``); when it fails on such an input, the
    cost is llmpas's default lower bound (said once)."""

    fn: Callable[..., Any]
    notes: Notes
    name: str

    def __call__(self, *inputs: Any) -> Any:
        try:
            return self.fn(*inputs)
        except Exception:
            if all(x is not None for x in inputs):
                raise
            self.notes.ignored(
                f"FunctionInfo(opt_fn) of {self.name}",
                f"it failed on an input not computed yet: {OPT_DEFAULT:g} is used",
            )
            return OPT_DEFAULT


@dataclass(frozen=True)
class ExternalInfo:
    """Options of one stream or function (PDDLStream's ``StreamInfo``/``FunctionInfo``)."""

    options: tuple[tuple[str, Any], ...] = ()
    kind: str = "stream"

    @property
    def label(self) -> str:
        return "StreamInfo" if self.kind == "stream" else "FunctionInfo"

    def native(self, notes: Notes, name: str) -> NativeInfo:
        """llmpas's options; every option that means nothing here is noted (once per run)."""
        opts = dict(self.options)
        p_success = opts.get("p_success")
        kwargs: dict[str, Any] = {}
        if opts.get("eager") and self.kind == "stream":
            kwargs["eager"] = True
        if p_success is not None:
            kwargs["p_success"] = max(0.0, min(1.0, float(p_success)))
        if opts.get("overhead") is not None:
            kwargs["overhead"] = float(opts["overhead"])
        if opts.get("opt_fn") is not None and self.kind == "function":
            kwargs["opt_fn"] = _Optimistic(opts["opt_fn"], notes, name)
        for key, value in self.options:
            if key in _USED and not (key == "opt_fn" and self.kind != "function"):
                continue
            if key == "verbose" or (key in _SILENT and value in (None, never_defer)):
                continue
            notes.ignored(f"{self.label}.{key}", _WHY.get(key, "no meaning here"), name)
        return NativeInfo(**kwargs)


def StreamInfo(opt_gen_fn: Any = None, **options: Any) -> ExternalInfo:
    """PDDLStream's ``StreamInfo`` (its first positional option: ``opt_gen_fn``)."""
    if opt_gen_fn is not None:
        options["opt_gen_fn"] = opt_gen_fn
    return ExternalInfo(tuple(sorted(options.items())), "stream")


def FunctionInfo(opt_fn: Any = None, **options: Any) -> ExternalInfo:
    """PDDLStream's ``FunctionInfo`` (its first positional option: ``opt_fn``)."""
    if opt_fn is not None:
        options["opt_fn"] = opt_fn
    return ExternalInfo(tuple(sorted(options.items())), "function")


PredicateInfo = FunctionInfo


@dataclass
class Notes:
    """What a run accepted but ignores, each said once (a warning naming it)."""

    said: set[str] = field(default_factory=set)

    def ignored(self, option: str, why: str, where: str = "") -> None:
        if option in self.said:
            return
        self.said.add(option)
        at = f" (first for {where})" if where else ""
        log.warning("pddlstream: %s is accepted and ignored%s: %s", option, at, why)
