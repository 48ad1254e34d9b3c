"""``argparse`` types for option values: finite positive numbers, bounded counts, seeds.

A bad value is refused while the command line is parsed, with one line naming the option:
``llmpas plan: error: argument --max-time: expected a finite number > 0, got 'nan'``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

MAX_SECONDS = 7 * 24 * 3600.0  # a week: any time limit above is a typo
MAX_COUNT = 1_000_000  # episodes, trials, rounds ...
MAX_SEED = 2**63 - 1
MAX_EXAMPLE_SIZE = 100  # objects or blocks of a shipped example


def _parse_int(text: str) -> int:
    try:
        if "_" in text:  # int() reads '1_000'; on a command line it is more likely a typo
            raise ValueError(text)
        return int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def positive_float(text: str) -> float:
    """Seconds and other amounts: a finite number > 0 (at most a week's worth of seconds)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and 0 < value <= MAX_SECONDS):
        raise argparse.ArgumentTypeError(
            f"expected a finite number > 0 and <= {MAX_SECONDS:g}, got {text!r}"
        )
    return value


def bounded_int(minimum: int, maximum: int) -> Callable[[str], int]:
    """An integer type in [minimum, maximum]."""

    def parse(text: str) -> int:
        value = _parse_int(text)
        if not minimum <= value <= maximum:
            raise argparse.ArgumentTypeError(
                f"expected a whole number from {minimum} to {maximum}, got {text!r}"
            )
        return value

    parse.__name__ = f"int_{minimum}_{maximum}"
    return parse


positive_int = bounded_int(1, MAX_COUNT)
seed = bounded_int(0, MAX_SEED)

__all__ = ["MAX_EXAMPLE_SIZE", "bounded_int", "positive_float", "positive_int", "seed"]
