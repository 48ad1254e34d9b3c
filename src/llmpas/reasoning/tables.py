"""The data a world hands the reasoner: the goal vocabulary, the prompt tables and the actions
as skill calls. A leaf: it imports only :mod:`llmpas.language`, so a world can build these values
without importing any reasoning code (the layer contracts in ``.importlinter`` hold worlds to it).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

NAME = re.compile(r"[a-z][a-z0-9_-]*\Z")
"""A predicate or object name as goals write it."""
RESERVED = frozenset({"and", "not"})
CONNECTIVES = frozenset(
    {
        "or",
        "imply",
        "exists",
        "forall",
        "when",
        "define",
        "either",
        "=",
        "<",
        ">",
        "<=",
        ">=",
        "increase",
        "decrease",
        "assign",
        "preference",
        "always",
        "sometime",
        "at-most-once",
        "sometime-after",
        "sometime-before",
    }
)


@dataclass(frozen=True)
class Vocabulary:
    """What goals may mention: goal predicates with, per argument, the set of allowed objects.

    ``predicates`` maps a lower-case predicate name to one non-empty set of allowed object names
    per argument position. Names must match ``[a-z][a-z0-9_-]*`` (upper case is lowered).
    """

    predicates: Mapping[str, tuple[frozenset[str], ...]]

    def __post_init__(self) -> None:
        if not isinstance(self.predicates, Mapping):
            raise TypeError(
                "predicates must be a mapping from name to allowed objects per argument"
            )
        table: dict[str, tuple[frozenset[str], ...]] = {}
        for name, positions in self.predicates.items():
            key = _valid_name(name, "predicate")
            if key in RESERVED or key in CONNECTIVES:
                raise ValueError(f"{key!r} is a PDDL keyword, not a goal predicate")
            if key in table:
                raise ValueError(f"predicate {key!r} is given twice")
            table[key] = _positions(key, positions)
        if not table:
            raise ValueError("a vocabulary needs at least one goal predicate")
        object.__setattr__(self, "predicates", MappingProxyType(dict(sorted(table.items()))))

    def __hash__(self) -> int:
        return hash(tuple(self.predicates.items()))

    @classmethod
    def of(cls, predicates: Mapping[str, Sequence[Iterable[str]]]) -> Vocabulary:
        """Build from any iterables: ``Vocabulary.of({"on": (objects, regions)})``."""
        return cls({k: tuple(frozenset(p) for p in v) for k, v in predicates.items()})

    @property
    def objects(self) -> frozenset[str]:
        """Every object some argument position allows."""
        return frozenset().union(*(s for allowed in self.predicates.values() for s in allowed))

    def arity(self, predicate: str) -> int | None:
        allowed = self.predicates.get(predicate)
        return None if allowed is None else len(allowed)

    def signature(self) -> str:
        """``cooked/1, holding/1, on/2`` (for messages)."""
        return ", ".join(f"{p}/{len(a)}" for p, a in self.predicates.items())

    def describe(self) -> str:
        """One line per predicate with its allowed objects (for prompts)."""
        lines = []
        for p, allowed in self.predicates.items():
            slots = " ".join(f"?a{i}" for i in range(1, len(allowed) + 1))
            where = "; ".join(
                f"?a{i} in {{{', '.join(sorted(s))}}}" for i, s in enumerate(allowed, 1)
            )
            lines.append(
                f"({p}{' ' + slots if slots else ''})" + (f" where {where}" if where else "")
            )
        return "\n".join(lines)


def _valid_name(name: object, what: str) -> str:
    if not isinstance(name, str):
        raise TypeError(f"{what} names must be strings, got {name!r}")
    key = name.lower()
    if not NAME.match(key):
        raise ValueError(f"invalid {what} name {name!r}: use [a-z][a-z0-9_-]*")
    return key


def _positions(predicate: str, positions: object) -> tuple[frozenset[str], ...]:
    if isinstance(positions, str | bytes) or not isinstance(positions, Iterable):
        raise TypeError(f"{predicate!r}: give one collection of allowed objects per argument")
    out = []
    for i, allowed in enumerate(positions, 1):
        if isinstance(allowed, str | bytes) or not isinstance(allowed, Iterable):
            raise TypeError(f"{predicate!r} argument {i}: give a collection of object names")
        names = frozenset(_valid_name(o, "object") for o in allowed)
        if not names:
            raise ValueError(f"{predicate!r} argument {i} allows no object")
        out.append(names)
    return tuple(out)


@dataclass(frozen=True)
class Call:
    """What an action call means as a goal: ``(predicate args...)``, possibly negated, with the
    call's arguments at ``positions``."""

    params: tuple[str, ...]
    predicate: str
    positions: tuple[int, ...]
    negated: bool = False

    def signature(self, name: str) -> str:
        return f"def {name}({', '.join(self.params)}): ..."


@dataclass(frozen=True)
class PromptTables:
    """``actions``: name -> (what it does, predicates it makes true); ``predicates``: name ->
    (parameters, meaning); ``calls``: the actions as functions; ``objects``: the scenario's
    objects (for program-style prompts)."""

    actions: Mapping[str, tuple[str, tuple[str, ...]]]
    predicates: Mapping[str, tuple[str, str]]
    calls: Mapping[str, Call] = field(default_factory=dict)
    objects: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.actions or not self.predicates:
            raise ValueError("prompt tables need at least one action and one predicate")
        for name, call in self.calls.items():
            if call.predicate not in self.predicates:
                raise ValueError(f"call {name!r} makes {call.predicate!r}, not a listed predicate")
        object.__setattr__(self, "actions", MappingProxyType(dict(self.actions)))
        object.__setattr__(self, "predicates", MappingProxyType(dict(self.predicates)))
        object.__setattr__(self, "calls", MappingProxyType(dict(self.calls)))

    def action_library(self) -> str:
        lines = []
        for name, (text, makes) in self.actions.items():
            made = f" — makes true: {', '.join(makes)}" if makes else ""
            lines.append(f"- {name}: {text}{made}")
        return "\n".join(lines)

    def predicate_list(self) -> str:
        return "\n".join(f"- ({n} {args}): {text}" for n, (args, text) in self.predicates.items())


__all__ = ["CONNECTIVES", "NAME", "RESERVED", "Call", "PromptTables", "Vocabulary"]
