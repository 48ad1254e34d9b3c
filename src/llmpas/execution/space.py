"""The constraint space of one conditional subtree, explored by conditional samplers.

A :class:`ConstraintSpace` is an ordered list of :class:`Dimension` s (e.g. search region, base
pose, grasp). Each dimension draws values from a conditional sampler given the values chosen so far
(and whatever the executor perceived since). Values are drawn lazily, when a sub-action first needs
them. When a constraint fails, :meth:`ConstraintSpace.backtrack` advances the deepest dimension the
constraint depends on and forgets every deeper one (conflict-directed backtracking); when a
dimension runs dry, the next shallower one advances. Every dimension has a budget, the whole space
has one, and every value tried is recorded — exploration is exhaustive within the budgets and
always ends.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

Sampler = Callable[[Mapping[str, Any]], Iterable[Any]]


class _NoSample:
    def __repr__(self) -> str:
        return "NO_SAMPLE"


#: What a sampler yields for "nothing this time" (a stream's ``None``): it uses up one draw of the
#: dimension's budget, so a sampler that never produces a value cannot hang the space.
NO_SAMPLE: Any = _NoSample()


@dataclass(frozen=True)
class Dimension:
    """One axis of the constraint space.

    ``sampler(values)`` gets the values of every parameter known so far (plan bindings, earlier
    dimensions, perceptions) and yields candidate values for ``name``. ``budget`` bounds how many
    values are tried for one setting of the earlier dimensions.
    """

    name: str
    sampler: Sampler
    budget: int = 5
    describe: Callable[[Any], str] = repr

    def __post_init__(self) -> None:
        if self.budget < 1:
            raise ValueError(f"dimension {self.name!r}: budget must be >= 1, got {self.budget}")


@dataclass(frozen=True)
class Sample:
    """A value tried for a dimension, with the attempt it belonged to."""

    dimension: str
    value: str
    attempt: int


@dataclass
class _Slot:
    iterator: Iterator[Any]
    value: Any = None
    drawn: int = 0


class Exhausted(Exception):
    """No value is left within the budgets (raised by :meth:`ConstraintSpace.value`)."""


@dataclass
class ConstraintSpace:
    dims: tuple[Dimension, ...]
    fixed: Mapping[str, Any] = field(default_factory=dict)
    max_samples: int = 50  # values drawn over the whole space

    def __post_init__(self) -> None:
        names = [d.name for d in self.dims]
        if len(set(names)) != len(names):
            raise ValueError(f"dimension names repeat: {names}")
        if self.max_samples < 1:
            raise ValueError(f"max_samples must be >= 1, got {self.max_samples}")
        self._slots: list[_Slot] = []
        self.extra: dict[str, Any] = {}  # values perceived during execution (e.g. detected poses)
        self.samples: list[Sample] = []
        self.attempt = 0
        self.exhausted = False

    # ------------------------------------------------------------------ reading values
    def index(self, name: str) -> int:
        for i, d in enumerate(self.dims):
            if d.name == name:
                return i
        raise KeyError(f"no dimension {name!r}; dimensions are {[d.name for d in self.dims]}")

    def values(self) -> dict[str, Any]:
        """Every known value: fixed bindings, perceptions, and the dimensions drawn so far."""
        out = dict(self.fixed)
        out.update(self.extra)
        out.update({d.name: s.value for d, s in zip(self.dims, self._slots, strict=False)})
        return out

    def value(self, name: str) -> Any:
        """The current value of a dimension, drawing it (and the ones before it) if needed."""
        i = self.index(name)
        while len(self._slots) <= i:
            if self.exhausted:
                raise Exhausted(name)
            self._open(len(self._slots))
        return self._slots[i].value

    def ensure(self, names: Iterable[str]) -> dict[str, Any]:
        for n in names:
            self.value(n)
        return self.values()

    # ------------------------------------------------------------------ exploring
    def _draw(self, i: int, slot: _Slot) -> bool:
        d = self.dims[i]
        if slot.drawn >= d.budget or len(self.samples) >= self.max_samples:
            return False
        try:
            v = next(slot.iterator)
            while v is NO_SAMPLE:
                slot.drawn += 1
                if slot.drawn >= d.budget:
                    return False
                v = next(slot.iterator)
        except StopIteration:
            return False
        slot.value = v
        slot.drawn += 1
        self.samples.append(Sample(d.name, d.describe(v), self.attempt))
        return True

    def _open(self, i: int) -> None:
        """Start dimension ``i`` from a fresh sampler; backtrack further when it has nothing."""
        d = self.dims[i]
        slot = _Slot(iter(d.sampler(self.values())))
        if self._draw(i, slot):
            self._slots.append(slot)
            return
        if not self._advance(i - 1):
            self.exhausted = True
            raise Exhausted(d.name)

    def _advance(self, i: int) -> bool:
        """Next value of dimension ``i`` (deeper ones forgotten); shallower ones as needed."""
        while i >= 0:
            del self._slots[i + 1 :]
            if self._draw(i, self._slots[i]):
                return True
            del self._slots[i:]
            i -= 1
        return False

    def backtrack(self, culprits: Iterable[str] = ()) -> bool:
        """A constraint that depends on ``culprits`` failed: move to the next candidate.

        Returns False (and marks the space exhausted) when nothing is left within the budgets.
        """
        self.attempt += 1
        drawn = [self.index(c) for c in culprits if self.index(c) < len(self._slots)]
        if not drawn:
            drawn = [len(self._slots) - 1] if self._slots else []
        if not drawn:
            self.exhausted = True
            return False
        ok = self._advance(max(drawn))
        self.exhausted = not ok
        return ok

    def perceive(self, name: str, value: Any) -> None:
        """Record something perceived during execution, visible to later samplers."""
        self.extra[name] = value

    def tried(self) -> dict[str, list[str]]:
        out: dict[str, list[str]] = {d.name: [] for d in self.dims}
        for s in self.samples:
            out[s.dimension].append(s.value)
        return out
