"""Readers of the fields of parsed TOML (scenario files, task files): each returns the value
checked, or raises the reader's error with one line ``source: where: message``.

Shared by the household scenario parser (:mod:`llmpas.worlds.household.scenario`) and the task
files of the anomaly suite (:mod:`llmpas.experiments.suite.task_files`), so that both say the same
thing about the same mistake.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from llmpas.errors import InputError


def show(value: Any) -> str:
    """A value as a message shows it (strings quoted)."""
    return repr(value) if isinstance(value, str) else str(value)


class Fields:
    """Field readers for one file: ``source`` names it in messages, ``error`` is the class of
    what they raise (an :class:`~llmpas.errors.InputError`)."""

    def __init__(self, source: str, error: type[InputError] = InputError) -> None:
        self.source = source
        self.error = error

    def fail(self, where: str, message: str) -> InputError:
        return self.error(f"{self.source}: {where}: {message}")

    def table(self, value: Any, where: str, allowed: tuple[str, ...]) -> Mapping[str, Any]:
        """A table whose keys are all ``allowed``."""
        if not isinstance(value, Mapping):
            raise self.fail(where, f"must be a table, got {show(value)}")
        for key in value:
            if key not in allowed:
                raise self.fail(
                    f"{where}.{key}" if where else key,
                    f"unknown field; fields: {', '.join(allowed)}",
                )
        return value

    def array(self, value: Any, where: str) -> list[Any]:
        if not isinstance(value, list):
            raise self.fail(where, f"must be an array, got {show(value)}")
        return value

    def string(self, value: Any, where: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.fail(where, f"must be a non-empty string, got {show(value)}")
        return value

    def number(self, value: Any, where: str) -> float:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise self.fail(where, f"must be a finite number, got {show(value)}")
        return float(value)

    def integer(self, value: Any, where: str, minimum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(where, f"must be an integer, got {show(value)}")
        if minimum is not None and value < minimum:
            raise self.fail(where, f"must be at least {minimum}, got {value}")
        return value

    def boolean(self, value: Any, where: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(where, f"must be true or false, got {show(value)}")
        return value

    def probability(self, value: Any, where: str) -> float:
        p = self.number(value, where)
        if not 0.0 <= p <= 1.0:
            raise self.fail(where, f"must be a probability in [0, 1], got {show(value)}")
        return p

    def sigma(self, value: Any, where: str) -> float:
        """A standard deviation (or any amount): a finite number >= 0."""
        s = self.number(value, where)
        if s < 0.0:
            raise self.fail(where, f"must be >= 0, got {show(value)}")
        return s


__all__ = ["Fields", "show"]
