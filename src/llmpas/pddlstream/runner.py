"""``llmpas pddlstream SCRIPT ARGS``: run an unchanged PDDLStream script on llmpas's planner.

While the script runs, ``import pddlstream....`` resolves to this API (an import hook on
``sys.meta_path``, installed only here and only when no real ``pddlstream`` package can be
imported: a real installation is never shadowed). The script runs as ``python -m`` would run it
from the top of its package (a script inside ``examples/continuous_tamp/`` with
``__init__.py`` files up to ``examples/`` runs as ``examples.continuous_tamp.run`` with the
folder above ``examples/`` on ``sys.path``), or as a plain script. Every call of ``solve`` is
recorded and its plan validated by replay (:mod:`llmpas.pddlstream.solution_check`).
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import logging
import os
import runpy
import sys
import traceback
import types
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from llmpas.errors import ExitCode, InputError, LlmpasError, UsageError
from llmpas.pddlstream.compat import MODULE_NAMES, build_modules
from llmpas.pddlstream.solution_check import Validation, validate
from llmpas.pddlstream.solving import Attempt, SolveContext
from llmpas.pddlstream.translate import Unsupported

log = logging.getLogger(__name__)


class ScriptFailed(LlmpasError):
    """The script raised (after or without planning): one line naming where."""

    code = ExitCode.FAILED


class _AliasFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Serves ``pddlstream`` and its submodules from one run's alias modules."""

    def __init__(self, modules: dict[str, types.ModuleType]) -> None:
        self.modules = modules

    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None = None,
        target: types.ModuleType | None = None,
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname in self.modules:
            is_pkg = hasattr(self.modules[fullname], "__path__")
            return importlib.util.spec_from_loader(fullname, self, is_package=is_pkg)
        return None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        return self.modules[spec.name]

    def exec_module(self, module: types.ModuleType) -> None:
        """The module is complete already."""


@dataclass(frozen=True)
class Checked:
    attempt: Attempt
    validation: Validation


@dataclass
class Run:
    """What one script run did: every ``solve`` call, validated, and how the script ended."""

    script: str
    checked: list[Checked] = field(default_factory=list)
    exit_code: int = 0
    error: str = ""

    @property
    def planned(self) -> bool:
        return any(c.attempt.result.solved for c in self.checked)

    @property
    def validated(self) -> bool:
        solved = [c for c in self.checked if c.attempt.result.solved]
        return bool(solved) and all(c.validation.valid for c in solved)


def package_root(script: Path) -> tuple[Path, str | None]:
    """(folder to put on sys.path, module name) as ``python -m`` from the package's top would
    run ``script``; (its folder, None) for a script outside a package."""
    folder = script.parent
    parts = [script.stem]
    while (folder / "__init__.py").is_file():
        parts.insert(0, folder.name)
        folder = folder.parent
    if len(parts) == 1:
        return script.parent, None
    return folder, ".".join(parts)


def real_pddlstream() -> str | None:
    """Where a real ``pddlstream`` package would be imported from, or None."""
    loaded = sys.modules.get("pddlstream")
    if loaded is not None and not getattr(loaded, "__llmpas__", False):
        return str(getattr(loaded, "__file__", None) or loaded)
    try:
        spec = importlib.util.find_spec("pddlstream")
    except (ImportError, ValueError):
        return None
    if spec is None:
        return None
    return str(spec.origin or (list(spec.submodule_search_locations or []) or ["?"])[0])


def run_script(
    script: str, argv: Sequence[str] = (), validate_plans: bool = True, seed: int | None = None
) -> Run:
    """Run ``script`` with ``argv`` under this API (module docstring); never raises for what
    the script does: the :class:`Run` says how it ended. ``seed``: Python's and numpy's global
    random generators are seeded with it before the script runs (a script that seeds them
    itself overrides it), as :func:`seed_globals` does for a real PDDLStream's run."""
    path = Path(script)
    if not path.is_file():
        raise UsageError(f"pddlstream: {script}: no such script")
    root, module = package_root(path.resolve())
    run = Run(script)

    def record(attempt: Attempt) -> None:
        v = (
            validate(attempt)
            if validate_plans and attempt.result.solved
            else Validation(False, "not validated" if attempt.result.solved else "no plan")
        )
        run.checked.append(Checked(attempt, v))

    saved_path, saved_argv = list(sys.path), list(sys.argv)
    before = set(sys.modules)
    sys.path.insert(0, str(root))
    real = real_pddlstream()
    if real is not None:
        sys.path[:] = saved_path
        raise UsageError(
            f"pddlstream: a real PDDLStream is importable ({real}); llmpas does not shadow it: "
            "run the script with python, or take it off the path"
        )
    if seed is not None:
        seed_globals(seed)
    finder = _AliasFinder(build_modules(SolveContext(on_attempt=record)))
    sys.meta_path.insert(0, finder)
    sys.argv = [str(path), *argv]
    try:
        if module is not None:
            runpy.run_module(module, run_name="__main__", alter_sys=True)
        else:
            runpy.run_path(str(path), run_name="__main__")
    except SystemExit as e:
        code = e.code
        run.exit_code = code if isinstance(code, int) else (0 if code is None else 1)
        if isinstance(code, str):
            run.error = code
    except LlmpasError as e:
        run.exit_code, run.error = int(e.code), str(e)
    except ModuleNotFoundError as e:
        run.exit_code, run.error = _missing(e, path)
    except ImportError as e:
        if (e.name or "").split(".")[0] != "pddlstream":
            run.exit_code, run.error = int(ExitCode.FAILED), _where(e, root) + _message(e)
        else:
            err = Unsupported(f"{_where(e, root)}{e} (not part of llmpas's PDDLStream API)")
            run.exit_code, run.error = int(err.code), str(err)
    except KeyboardInterrupt:
        run.exit_code, run.error = int(ExitCode.INTERRUPTED), "interrupted"
    except Exception as e:  # the script's own code may raise anything
        run.exit_code, run.error = int(ExitCode.FAILED), _where(e, root) + _message(e)
        log.debug("the script raised", exc_info=True)
    finally:
        sys.meta_path.remove(finder)
        sys.path[:] = saved_path
        sys.argv = saved_argv
        for name in set(sys.modules) - before:
            if name.split(".")[0] == "pddlstream" or _under(sys.modules[name], root):
                del sys.modules[name]
    return run


def seed_globals(seed: int) -> None:
    """Seed the global generators PDDLStream's scripts draw from (``random``, ``numpy.random``):
    what a script run with a seed sees, here or under a real PDDLStream."""
    import random

    import numpy as np

    random.seed(seed)
    np.random.seed(seed % 2**32)


def _missing(e: ModuleNotFoundError, script: Path) -> tuple[int, str]:
    name = e.name or ""
    if name.split(".")[0] == "pddlstream" and name not in MODULE_NAMES:
        err: LlmpasError = Unsupported(
            f"{script}: {name} is not part of llmpas's PDDLStream API (see docs/pddlstream.md)"
        )
    else:
        err = InputError(f"{script}: the script imports {name!r}, which is not installed")
    return int(err.code), str(err)


def _message(e: BaseException) -> str:
    return f"{type(e).__name__}: {e}" if str(e) else type(e).__name__


def _where(e: BaseException, root: Path) -> str:
    """``file:line: `` of the deepest frame of the script's own code in ``e``'s traceback."""
    frames = [
        f
        for f in traceback.extract_tb(e.__traceback__)
        if _inside(f.filename, root) and "llmpas" not in Path(f.filename).parts
    ]
    if not frames:
        return ""
    f = frames[-1]
    return f"{os.path.relpath(f.filename)}:{f.lineno}: "


def _inside(filename: str, root: Path) -> bool:
    try:
        Path(filename).resolve().relative_to(root)
    except ValueError:
        return False
    return True


def _under(module: types.ModuleType | None, root: Path) -> bool:
    file = getattr(module, "__file__", None)
    return bool(file) and _inside(str(file), root)


__all__ = [
    "Checked",
    "Run",
    "ScriptFailed",
    "package_root",
    "real_pddlstream",
    "run_script",
    "seed_globals",
]
