"""PDDLStream's small helpers that example scripts import from ``pddlstream.utils``."""

from __future__ import annotations

import cProfile
import io
import itertools
import logging
import os
import pstats
import random
import shutil
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from llmpas.inputs import PDDL_LIMIT, read_text
from llmpas.pddlstream.expressions import INF, str_from_object
from llmpas.pddlstream.wrappers import negate_test

log = logging.getLogger(__name__)

SEPARATOR = "\n" + 80 * "-" + "\n"


class PddlText(str):
    """The text of a PDDL file that remembers its path (so that errors name the file)."""

    path: str

    def __new__(cls, text: str, path: str) -> PddlText:
        obj = super().__new__(cls, text)
        obj.path = path
        return obj


def read(filename: str | os.PathLike[str]) -> str:
    """A file's text (a PDDL file: at most the limit every llmpas input has)."""
    return PddlText(read_text(Path(filename), "file", PDDL_LIMIT), str(filename))


def get_file_path(file: str, rel_path: str) -> str:
    return os.path.join(os.path.dirname(os.path.abspath(file)), rel_path)


def read_pddl(this_file: str, pddl_filename: str) -> str:
    """The text of ``pddl_filename`` in the folder of ``this_file`` (a script's ``__file__``),
    as PDDLStream's ``read_pddl`` (cashpoint/run.py calls it so)."""
    return read(get_file_path(this_file, pddl_filename))


def read_relative(file: str, relative_path: str) -> str:
    """The text of ``relative_path`` from the folder of ``file`` (a script's ``__file__``)."""
    return read(get_file_path(file, relative_path))


def read_relative_dir(
    file: str, relative_dir: str = "./", filenames: Sequence[str] = ()
) -> list[str]:
    return [read_relative(file, os.path.join(relative_dir, name)) for name in filenames]


def read_pddl_pair(file: str, **kwargs: Any) -> list[str]:
    """``domain.pddl`` and ``problem.pddl`` next to ``file``."""
    return read_relative_dir(file, filenames=("domain.pddl", "problem.pddl"), **kwargs)


def read_pddlstream_pair(file: str, **kwargs: Any) -> list[str]:
    """``domain.pddl`` and ``stream.pddl`` next to ``file``."""
    return read_relative_dir(file, filenames=("domain.pddl", "stream.pddl"), **kwargs)


def write(filename: str, text: str) -> None:
    Path(filename).write_text(text, encoding="utf-8")


def ensure_dir(path: str) -> None:
    directory = os.path.dirname(path) if not path.endswith(os.sep) else path
    if directory:
        os.makedirs(directory, exist_ok=True)


def safe_rm_dir(path: str) -> None:
    if os.path.isdir(path):
        shutil.rmtree(path)


def user_input(message: str = "") -> str:
    """``input()``; at the end of input (no terminal): an empty answer."""
    try:
        return input(message)
    except EOFError:
        return ""


def elapsed_time(start: float) -> float:
    return time.time() - start


def implies(p: Any, q: Any) -> bool:
    return bool(not p or q)


def irange(start: int, stop: float | None = None, step: int = 1) -> Iterator[int]:
    if stop is None:
        start, stop = 0, start
    n = start
    while n < stop:
        yield n
        n += step


def inclusive_range(start: float, stop: float, step: float = 1) -> list[float]:
    out, n = [], 0
    while start + n * step <= stop:
        out.append(start + n * step)
        n += 1
    return out


def inf_generator() -> Iterator[int]:
    return itertools.count()


def find_unique(test: Callable[[Any], bool], sequence: Iterable[Any]) -> Any:
    found = [x for x in sequence if test(x)]
    if len(found) != 1:
        raise RuntimeError(f"expected one match, found {len(found)}")
    return found[0]


def randomize(sequence: Iterable[Any]) -> list[Any]:
    out = list(sequence)
    random.shuffle(out)
    return out


def flatten(iterables: Iterable[Iterable[Any]]) -> list[Any]:
    return [x for it in iterables for x in it]


def safe_zip(a: Sequence[Any], b: Sequence[Any]) -> list[tuple[Any, Any]]:
    if len(a) != len(b):
        raise ValueError(f"lengths differ: {len(a)} and {len(b)}")
    return list(zip(a, b, strict=True))


def str_eq(a: str, b: str, ignore_case: bool = True) -> bool:
    return a.lower() == b.lower() if ignore_case else a == b


def sorted_str_from_list(obj: Iterable[Any]) -> str:
    return str_from_object(sorted(map(str_from_object, obj)))


def value_or_id(value: Any) -> Any:
    try:
        hash(value)
    except TypeError:
        return id(value)
    return value


def neighbors_from_orders(orders: Iterable[tuple[Any, Any]]) -> tuple[dict[Any, set[Any]], ...]:
    incoming: dict[Any, set[Any]] = {}
    outgoing: dict[Any, set[Any]] = {}
    for a, b in orders:
        incoming.setdefault(b, set()).add(a)
        outgoing.setdefault(a, set()).add(b)
    return incoming, outgoing


class Profiler:
    """``with Profiler(field='cumtime', num=20):`` profiles the block and logs the top lines
    (at debug level: profiles are not part of a run's output)."""

    def __init__(self, field: str | None = "tottime", num: int = 10) -> None:
        self.field = field
        self.num = num
        self.profiler = cProfile.Profile() if field is not None else None

    def __enter__(self) -> Profiler:
        if self.profiler is not None and log.isEnabledFor(logging.DEBUG):
            self.profiler.enable()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self.profiler is None or not log.isEnabledFor(logging.DEBUG):
            return
        self.profiler.disable()
        out = io.StringIO()
        pstats.Stats(self.profiler, stream=out).sort_stats(self.field or "tottime").print_stats(
            self.num
        )
        log.debug("%s", out.getvalue())


__all__ = [
    "INF",
    "SEPARATOR",
    "PddlText",
    "Profiler",
    "elapsed_time",
    "ensure_dir",
    "find_unique",
    "flatten",
    "get_file_path",
    "implies",
    "inclusive_range",
    "inf_generator",
    "irange",
    "negate_test",
    "randomize",
    "read",
    "read_pddl",
    "safe_rm_dir",
    "safe_zip",
    "sorted_str_from_list",
    "str_eq",
    "str_from_object",
    "user_input",
    "value_or_id",
    "write",
]
