"""Shipped example problems, by name.

Every example builds a :class:`~llmpas.language.problem.Problem` from a size (blocks or
objects) and a seed; its PDDL files are package data located with :mod:`importlib.resources`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

from llmpas.examples import blocksworld, mobile, tamp2d
from llmpas.language.problem import Problem


@dataclass(frozen=True)
class Example:
    name: str
    description: str
    make_problem: Callable[[int, int], Problem]  # (size, seed)
    default_size: int
    sizes: tuple[int, ...]  # sizes for the planning-time benchmark


EXAMPLES: Mapping[str, Example] = MappingProxyType(
    {
        "blocksworld": Example(
            "blocksworld",
            "Classic four-operator blocks world; size = number of blocks; no streams.",
            blocksworld.make_problem,
            5,
            (4, 8, 12, 16, 20),
        ),
        "tamp2d": Example(
            "tamp2d",
            "A gripper moves blocks between regions of a 1-D table; size = number of blocks, "
            "each with its own goal region; streams sample poses, IK, motions, collisions "
            "(IK and motions deferred by default).",
            tamp2d.make_problem,
            2,
            (2, 4, 6, 8),
        ),
        "mobile": Example(
            "mobile",
            "Mobile manipulation in a kitchen (tables, sink, stove); size = number of objects, "
            "each to be moved, cleaned or cooked; base motion (RRT) and IK deferred by default.",
            mobile.make_problem,
            2,
            (1, 2, 3, 4, 6, 8),
        ),
    }
)


def get_example(name: str) -> Example:
    """The example called ``name`` (case-insensitive)."""
    try:
        return EXAMPLES[name.lower()]
    except KeyError:
        known = ", ".join(sorted(EXAMPLES))
        raise KeyError(f"unknown example {name!r}; known examples: {known}") from None


__all__ = ["EXAMPLES", "Example", "get_example"]
