"""The planner's extension points as lazy registries: planning algorithms and classical planners.

An :class:`Entry` names its implementation as ``"module:attribute"``; the module is imported the
first time the entry is used (:meth:`Entry.load`), as unified-planning's engine factory does, so
that listing the choices (``llmpas plan --help``) imports no planner.

- :data:`ALGORITHMS`: a function ``(run: llmpas.planning.planner_run.Run) -> PlanResult`` that plans
  one call of :func:`~llmpas.planning.tamp.solve` (``PlannerConfig.algorithm``).
- :data:`CLASSICAL_PLANNERS`: a factory ``(search: str, config: PlannerConfig) ->
  ClassicalPlanner`` (:class:`~llmpas.planning.downward.ClassicalPlanner`); ``search`` is the Fast
  Downward search string the quality chose for the next search (a planner that is not Fast
  Downward may ignore it) (``PlannerConfig.classical``).

Both are plain read-only mappings: a new algorithm or classical planner is one new module and
one line here. :func:`algorithm_names` and :func:`classical_names` are the choices the command
line and the configuration accept.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

_NAME = re.compile(r"[a-z][a-z0-9-]*")
_TARGET = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_]\w*")


@dataclass(frozen=True)
class Entry:
    """A registered implementation: ``target`` is ``"package.module:attribute"``;
    ``supports``: what it can do beyond the basics (an algorithm: ``fluents``, fluent streams)."""

    name: str
    target: str
    description: str
    supports: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        if not _NAME.fullmatch(self.name):
            raise ValueError(f"registry name {self.name!r}: lower-case letters, digits and '-'")
        if not _TARGET.fullmatch(self.target):
            raise ValueError(f"{self.name}: target must be 'module:attribute', got {self.target!r}")

    def load(self) -> Any:
        """The implementation (its module imported now, once)."""
        module, attribute = self.target.split(":")
        return getattr(importlib.import_module(module), attribute)


def _table(*entries: Entry) -> Mapping[str, Entry]:
    return MappingProxyType({e.name: e for e in entries})


ALGORITHMS: Mapping[str, Entry] = _table(
    Entry(
        "focused",
        "llmpas.planning.tamp:plan_focused",
        "optimistic stream instances, evaluated only where a plan needs them (adaptive)",
        supports=frozenset({"fluents"}),
    ),
    Entry(
        "skeletons",
        "llmpas.planning.tamp:plan_skeletons",
        "focused, with failed plans kept as skeletons and drawn again (PDDLStream's adaptive)",
        supports=frozenset({"fluents"}),
    ),
    Entry(
        "incremental",
        "llmpas.planning.tamp:plan_incremental",
        "every stream instance evaluated once per level, then a search",
    ),
)

CLASSICAL_PLANNERS: Mapping[str, Entry] = _table(
    Entry(
        "fast-downward",
        "llmpas.planning.downward:fast_downward",
        "Fast Downward (translator in a forked child, search binary under rlimits)",
    ),
)

DEFAULT_ALGORITHM = "focused"
DEFAULT_CLASSICAL = "fast-downward"


def algorithm_names() -> tuple[str, ...]:
    """The registered algorithms (the choices of ``--algorithm``)."""
    return tuple(ALGORITHMS)


def classical_names() -> tuple[str, ...]:
    """The registered classical planners (the choices of ``--classical``)."""
    return tuple(CLASSICAL_PLANNERS)


def _entry(table: Mapping[str, Entry], what: str, name: str) -> Entry:
    try:
        return table[name]
    except KeyError:
        raise ValueError(f"unknown {what} {name!r}; choose one of {', '.join(table)}") from None


def algorithm(name: str) -> Entry:
    """The registered algorithm ``name``; ``ValueError`` naming the choices otherwise."""
    return _entry(ALGORITHMS, "algorithm", name)


def classical_planner(name: str) -> Entry:
    """The registered classical planner ``name``; ``ValueError`` naming the choices otherwise."""
    return _entry(CLASSICAL_PLANNERS, "classical planner", name)


__all__ = [
    "ALGORITHMS",
    "CLASSICAL_PLANNERS",
    "DEFAULT_ALGORITHM",
    "DEFAULT_CLASSICAL",
    "Entry",
    "algorithm",
    "algorithm_names",
    "classical_names",
    "classical_planner",
]
