"""The product's registry: worlds (with their oracles), simulated robots and ``--llm`` specs,
read by ``llmpas run`` and by the benchmarks alike.

A shipped world is one folder under :mod:`llmpas.worlds` whose ``__init__.py`` registers it
(:class:`~llmpas.worlds.api.WorldEntry` as ``WORLD_ENTRY``; a simulated robot:
:class:`~llmpas.worlds.api.RobotEntry` as ``ROBOT_ENTRY``); they are found here by walking the
package, and no list of their names is kept anywhere else. A user's world is
``package.module:ATTR`` (a :class:`~llmpas.worlds.api.World`), imported only when asked for, its
oracle an ``oracle(session)`` function beside it.

An ``--llm`` spec is any kind of the backend registry
(:data:`~llmpas.reasoning.backends.backend_registry.KINDS`); its two recovery methods that ask
no model,
``oracle`` (:mod:`llmpas.reasoning.truth_oracle`) and ``replan``
(:mod:`llmpas.reasoning.replan`), are built here, where the world is known (:func:`llm_for`).

It sits in :mod:`llmpas.system` beside the entry points (:mod:`.run`) it feeds, and like them it
imports no world: a world is reached by name, as a plug-in (``importlib``), never by an import
statement (the import-linter contracts hold on the code as written).
"""

from __future__ import annotations

import importlib
import os
import pkgutil
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from llmpas.errors import UsageError
from llmpas.worlds.api import RobotEntry, World, WorldEntry

if TYPE_CHECKING:  # the loop and the backends load when an LLM is built, not for a listing
    from llmpas.system.llm_factories import LLMFactory, LLMFor

SHIPPED = "llmpas.worlds"
"""The package whose subpackages are the shipped worlds and robots."""


def _registrations(attr: str) -> Iterator[Any]:
    """``attr`` of every subpackage of :data:`SHIPPED` that has one (a package that cannot be
    imported, for an extra not installed, registers nothing)."""
    package = importlib.import_module(SHIPPED)
    for info in pkgutil.iter_modules(package.__path__, f"{SHIPPED}."):
        if not info.ispkg:
            continue
        try:
            module = importlib.import_module(info.name)
        except ImportError:
            continue
        found = getattr(module, attr, None)
        if found is not None:
            yield found


def worlds() -> Mapping[str, WorldEntry]:
    """The shipped worlds by name, in the order they are listed (by rank, then name)."""
    found = [e for e in _registrations("WORLD_ENTRY") if isinstance(e, WorldEntry)]
    return MappingProxyType({e.name: e for e in sorted(found, key=lambda e: (e.rank, e.name))})


def robots() -> Mapping[str, RobotEntry]:
    """The shipped simulated robots by name (``llmpas robot NAME``)."""
    found = [e for e in _registrations("ROBOT_ENTRY") if isinstance(e, RobotEntry)]
    return MappingProxyType({e.name: e for e in sorted(found, key=lambda e: e.name)})


def file_world() -> WorldEntry | None:
    """The shipped world that reads scenario files (a ``.toml`` file is its scenario)."""
    return next((e for e in worlds().values() if e.files), None)


def judged_task(world: str, path: str) -> tuple[Any, str] | None:
    """A judged task file of ``world`` (its registration's ``tasks`` hook): its scenario and its
    intent; None when the world reads no judged tasks or the file is not one. A broken task is
    the world's one-line :class:`~llmpas.errors.InputError`."""
    entry = worlds().get(world)
    if entry is None or not entry.tasks or not path.endswith(".toml"):
        return None
    found: tuple[Any, str] | None = _attr(entry.tasks, "tasks")(path)
    return found


def site_world() -> WorldEntry | None:
    """The shipped world that reads a site file (``--site``)."""
    return next((e for e in worlds().values() if e.sites), None)


def world_help() -> str:
    """The worlds the ``--world`` option's help names."""
    named = [e.name for e in worlds().values() if e.help]
    return ", ".join(named)


def scenario_help() -> str:
    """The scenarios the help of ``llmpas run`` names: each world's, the file world's last."""
    entries = [e for e in worlds().values() if e.help]
    ordered = [e for e in entries if not e.files] + [e for e in entries if e.files]
    return ", ".join(e.help for e in ordered)


def _attr(spec: str, what: str) -> Any:
    """``module:attr``, imported (one-line errors naming the spec)."""
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        known = ", ".join(worlds())
        raise UsageError(f"--world {spec!r}: expected one of {known} or package.module:ATTR")
    try:
        with _quiet():
            found = importlib.import_module(module)
    except ImportError as err:
        raise UsageError(f"{what} {spec!r}: cannot import {module}: {err}") from None
    if not hasattr(found, attr):
        raise UsageError(f"{what} {spec!r}: {module} has no attribute {attr!r}")
    return getattr(found, attr)


@contextmanager
def _quiet() -> Iterator[None]:
    """stderr to /dev/null while a world's modules load (pybullet prints its build date)."""
    saved, devnull = os.dup(2), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def load_world(spec: str) -> World:
    """A registered world by name, or ``package.module:ATTR``."""
    entry = worlds().get(spec)
    world = _attr(entry.world if entry else spec, "world")
    if not isinstance(world, World):
        raise UsageError(
            f"world {spec!r} does not implement the World protocol (llmpas.worlds.api)"
        )
    return world


def robot_command(kind: str) -> Callable[[Sequence[str]], int]:
    """The command of a registered simulated robot (``llmpas robot KIND``)."""
    known = robots()
    if kind not in known:
        raise UsageError(f"robot {kind!r}: known robots: {', '.join(sorted(known))}")
    command: Callable[[Sequence[str]], int] = _attr(known[kind].command, "robot")
    return command


def world_of(scenario: str, names: Sequence[str] | None = None) -> str:
    """The registered world that ships ``scenario`` (a file: the file world's); ``names``: the
    worlds asked (default: all)."""
    reader = file_world()
    try:
        if reader is not None and (scenario.endswith(".toml") or Path(scenario).exists()):
            return reader.name
    except OSError as e:  # a name too long for a path, say
        raise UsageError(f"scenario {scenario[:60]!r}: {e.strerror or e}") from None
    known: dict[str, list[str]] = {}
    for name in worlds() if names is None else names:
        try:
            shipped = load_world(name).scenarios()
        except UsageError:  # a world whose extra is not installed
            continue
        if scenario in shipped:
            return name
        known[name] = sorted(shipped)
    listed = "; ".join(f"{n}: {', '.join(s)}" for n, s in known.items())
    raise UsageError(f"no scenario {scenario!r}; known scenarios: {listed}")


def scenario_arg(world: str, name: str) -> str:
    """What ``world`` opens for the scenario ``name``: the file world reads a scenario file
    (a shipped name or a path); the others take their shipped names (an unknown name: a usage
    error listing them)."""
    entry = worlds().get(world)
    if entry is None or not entry.files:
        known = load_world(world).scenarios()
        if name not in known and not Path(name).is_file():
            raise UsageError(f"no scenario {name!r} in {world}; known: {', '.join(sorted(known))}")
        return name
    path_of: Callable[[str], Path] = _attr(entry.files, "scenario files")
    try:
        return str(path_of(name))
    except FileNotFoundError as e:
        raise UsageError(str(e)) from None
    except OSError as e:  # a name too long for a path, say
        raise UsageError(f"scenario {name!r}: {e.strerror or e}") from None


def oracle_for(world: str) -> LLMFor:
    """The labelled oracle of a world (a function of its session)."""
    entry = worlds().get(world)
    if entry is not None and entry.oracle:
        return _attr(entry.oracle, "oracle")
    # a user's world: an ``oracle(session)`` function beside its world object
    return _attr(f"{world.partition(':')[0]}:oracle", "oracle")


def llm_for(
    spec: str, record: str | None = None, world: str | None = None, method: str = "flp"
) -> LLMFactory:
    """The loop's LLM for an ``--llm`` spec (any kind of the backend registry,
    :data:`~llmpas.reasoning.backends.backend_registry.KINDS`), as the loop takes it: a factory of
    the
    session. ``oracle``: the world's labelled oracle (default: the file world's); ``replan``: no
    reasoning, the session's task restated (in ``method``'s answer form); any other: that
    backend, :func:`~llmpas.system.llm_factories.fixed`."""
    from llmpas.reasoning.backends.backend_registry import make_backend
    from llmpas.reasoning.replan import REPLAN, Replan
    from llmpas.reasoning.truth_oracle import ORACLE
    from llmpas.system.llm_factories import as_factory

    def oracle(arg: str, rec: str | None) -> LLMFor:
        if rec:
            raise ValueError("--record does not apply to the oracle")
        reader = file_world()
        return oracle_for(world or (reader.name if reader else ""))

    def replan(arg: str, rec: str | None) -> LLMFor:
        if rec or arg:
            raise ValueError("replan takes no argument and records nothing (it is no LLM)")
        return lambda session: Replan(session.task, method)

    built = make_backend(spec, record, {ORACLE: oracle, REPLAN: replan})
    return as_factory(built)


__all__ = [
    "SHIPPED",
    "file_world",
    "llm_for",
    "load_world",
    "oracle_for",
    "robot_command",
    "robots",
    "scenario_arg",
    "scenario_help",
    "site_world",
    "world_help",
    "world_of",
    "worlds",
]
