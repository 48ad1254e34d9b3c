"""Loading stream implementations named on the command line: ``FILE.py:NAME`` or ``MODULE:NAME``.

The file is read like every input (a regular UTF-8 file under a size cap), compiled and run
once, with a time limit; whatever goes wrong (a syntax error, an exception or ``sys.exit`` while
it runs, a missing name, a value that is not a mapping of stream names to callables) is an
:class:`~llmpas.errors.InputError` of one line naming the file (and the line where known).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
import traceback
import types
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from llmpas.errors import InputError, UsageError
from llmpas.inputs import PYTHON_LIMIT, read_text
from llmpas.language.bindings import Implementation
from llmpas.limits import TimeLimitExpired, time_limit

IMPORT_SECONDS = 30.0  # running a bindings file (or calling its factory) at most this long


def load_bindings(spec: str, seconds: float = IMPORT_SECONDS) -> Mapping[str, Any]:
    """``MODULE:NAME`` or ``path/to/file.py:NAME`` -> the mapping stream name -> implementation.

    ``NAME`` may also be a function of no arguments returning the mapping."""
    return load_bindings_and_values(spec, seconds)[0]


def load_bindings_and_values(
    spec: str, seconds: float = IMPORT_SECONDS
) -> tuple[Mapping[str, Any], Mapping[str, Any]]:
    """:func:`load_bindings`, and the module's ``VALUES`` (object name -> Python value, the
    values of a problem file's objects; empty when the module has none)."""
    where, _, attr = spec.rpartition(":")
    if not where or not attr.isidentifier():
        raise UsageError(f"--bindings {spec!r}: expected MODULE:NAME or FILE.py:NAME")
    is_file = where.endswith(".py") or "/" in where or os.sep in where or Path(where).exists()
    label = where if is_file else f"module {where}"
    late = InputError(f"{label}: loading the bindings took longer than {seconds:g} s")
    with time_limit(seconds, late):
        module = _load_file(where) if is_file else _load_module(where)
        if not hasattr(module, attr):
            raise InputError(f"{label}: defines no {attr!r} (--bindings {spec})")
        obj = getattr(module, attr)
        if callable(obj) and not isinstance(obj, Mapping):
            obj = _guarded(obj, where, f"calling {attr}()")
        impls = _guarded(lambda: _check_mapping(obj, f"{label}: {attr}"), where, "reading it")
        values = getattr(module, "VALUES", {})
        if not isinstance(values, Mapping) or not all(isinstance(k, str) for k in values):
            raise InputError(
                f"{label}: VALUES is {type(values).__name__}, not a mapping object name -> value"
            )
        return impls, values


def _load_module(name: str) -> Any:
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as e:
        raise InputError(f"--bindings: no module named {e.name or name!r}") from None
    except (ImportError, ValueError, TypeError) as e:  # bad names: '..x', 'a..b'
        raise InputError(f"--bindings: module {name!r} cannot be imported: {e}") from None


def _load_file(where: str) -> types.ModuleType:
    text = read_text(where, "Python bindings file", PYTHON_LIMIT)
    try:
        code = compile(text, where, "exec")
    except SyntaxError as e:
        raise InputError(f"{where}:{e.lineno or 0}:{e.offset or 0}: {e.msg}") from None
    except (RecursionError, MemoryError, ValueError) as e:
        raise InputError(f"{where}: cannot be compiled: {type(e).__name__}: {e}") from None
    digest = hashlib.sha256(str(Path(where).resolve()).encode()).hexdigest()[:12]
    name = f"llmpas_bindings_{digest}"
    module = types.ModuleType(name)
    module.__file__ = str(Path(where).resolve())
    sys.modules[name] = module  # dataclasses and pickle look classes up by module name
    try:
        _guarded(lambda: exec(code, module.__dict__), where, "running it")
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _guarded(fn: Callable[[], Any], where: str, doing: str) -> Any:
    """``fn()``, with anything it raises (``SystemExit`` included) as one InputError."""
    try:
        return fn()
    except (KeyboardInterrupt, InputError, TimeLimitExpired):
        raise
    except SystemExit as e:
        raise InputError(f"{where}: {doing} called sys.exit({e.code!r})") from None
    except BaseException as e:  # user code may raise anything
        line = _line_in(e, where)
        place = f"{where}:{line}" if line else where
        message = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
        raise InputError(f"{place}: {doing} raised {message}") from None


def _line_in(e: BaseException, where: str) -> int | None:
    """The last line of ``where`` in ``e``'s traceback."""
    lines = [f.lineno for f in traceback.extract_tb(e.__traceback__) if f.filename == where]
    return lines[-1] if lines else None


def _check_mapping(obj: Any, label: str) -> Mapping[str, Any]:
    if not isinstance(obj, Mapping):
        raise InputError(
            f"{label} is {type(obj).__name__}, not a mapping of stream name -> implementation"
        )
    for key, value in obj.items():
        if not isinstance(key, str) or not key:
            raise InputError(f"{label}: key {key!r} is not a stream name (a non-empty string)")
        if not (isinstance(value, Implementation) or callable(value)):
            raise InputError(f"{label}[{key!r}] is {type(value).__name__}, not callable")
    return obj


__all__ = ["IMPORT_SECONDS", "load_bindings", "load_bindings_and_values"]
