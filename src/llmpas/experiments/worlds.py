"""Worlds by name, and their labelled oracles.

A world is named ``household``, ``pybullet``, ``tabletop`` or ``package.module:ATTR`` (a user's
own :class:`~llmpas.worlds.api.World`), imported only when asked for. A world's oracle (which
reads its truth; an upper bound, never a default) is found in :data:`ORACLES`, or as an
``oracle(session)`` function beside a user's world object.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from llmpas.errors import UsageError
from llmpas.experiments.replan import REPLAN, Replan
from llmpas.reasoning.backends.registry import make_backend
from llmpas.reasoning.llm import LLM
from llmpas.system import LLMFactory, LLMFor, LoopResult, LoopSettings, OnRound, as_factory, run
from llmpas.worlds.api import RunOptions, World

WORLDS = MappingProxyType(
    {
        "household": "llmpas.worlds.household.plugin:WORLD",
        "pybullet": "llmpas.worlds.pybullet.plugin:WORLD",
        "tabletop": "llmpas.worlds.tabletop:WORLD",
        "ros2": "llmpas.worlds.ros2.plugin:WORLD",
    }
)
ORACLES = MappingProxyType(
    {
        "household": "llmpas.experiments.oracles.household:oracle",
        "pybullet": "llmpas.experiments.oracles.pybullet:oracle",
        "tabletop": "llmpas.experiments.oracles.tabletop:oracle",
        "ros2": "llmpas.experiments.oracles.pybullet:oracle",
    }
)
ORACLE = "oracle"
# ``llmpas robot KIND ARGS``: the command of a world that serves a simulated robot, run(argv) -> int
ROBOTS = MappingProxyType({"pybullet": "llmpas.worlds.pybullet_ros2.command:run"})


def _attr(spec: str, what: str) -> Any:
    """``module:attr``, imported (one-line errors naming the spec)."""
    module, sep, attr = spec.partition(":")
    if not sep or not module or not attr:
        known = ", ".join(WORLDS)
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
    world = _attr(WORLDS.get(spec, spec), "world")
    if not isinstance(world, World):
        raise UsageError(
            f"world {spec!r} does not implement the World protocol (llmpas.worlds.api)"
        )
    return world


def robot_command(kind: str) -> Callable[[Sequence[str]], int]:
    """The command of a registered simulated robot (``llmpas robot KIND``)."""
    if kind not in ROBOTS:
        raise UsageError(f"robot {kind!r}: known robots: {', '.join(sorted(ROBOTS))}")
    command: Callable[[Sequence[str]], int] = _attr(ROBOTS[kind], "robot")
    return command


def world_of(scenario: str, worlds: tuple[str, ...] = tuple(WORLDS)) -> str:
    """The registered world that ships ``scenario`` (a file: the household's)."""
    try:
        if scenario.endswith(".toml") or Path(scenario).exists():
            return "household"
    except OSError as e:  # a name too long for a path, say
        raise UsageError(f"scenario {scenario[:60]!r}: {e.strerror or e}") from None
    known: dict[str, list[str]] = {}
    for name in worlds:
        try:
            shipped = load_world(name).scenarios()
        except UsageError:  # a world whose extra is not installed
            continue
        if scenario in shipped:
            return name
        known[name] = sorted(shipped)
    listed = "; ".join(f"{n}: {', '.join(s)}" for n, s in known.items())
    raise UsageError(f"no scenario {scenario!r}; known scenarios: {listed}")


def oracle_for(world: str) -> LLMFor:
    """The labelled oracle of a world (a function of its session)."""
    if world in ORACLES:
        return _attr(ORACLES[world], "oracle")
    # a user's world: an ``oracle(session)`` function beside its world object
    return _attr(f"{world.partition(':')[0]}:oracle", "oracle")


def llm_for(
    spec: str, record: str | None = None, world: str = "household", method: str = "flp"
) -> LLMFactory:
    """The loop's LLM for an ``--llm`` spec (any kind of the backend registry,
    :data:`~llmpas.reasoning.backends.registry.KINDS`), as the loop takes it: a factory of the
    session. ``oracle``: the world's labelled oracle; ``replan``: no reasoning, the session's
    task restated (in ``method``'s answer form); any other: that backend, :func:`fixed`."""

    def oracle(arg: str, rec: str | None) -> LLMFor:
        if rec:
            raise ValueError("--record does not apply to the oracle")
        return oracle_for(world)

    def replan(arg: str, rec: str | None) -> LLMFor:
        if rec or arg:
            raise ValueError("replan takes no argument and records nothing (it is no LLM)")
        return lambda session: Replan(session.task, method)

    built = make_backend(spec, record, {ORACLE: oracle, REPLAN: replan})
    return as_factory(built)


@dataclass(frozen=True)
class LoopConfig(LoopSettings):
    """How an experiment runs the loop: how it reasons and how the world runs."""

    options: RunOptions = field(default_factory=RunOptions)


def run_loop(
    scenario: Any,
    llm: LLM | LLMFor | str = ORACLE,
    config: LoopSettings | None = None,
    out: str | Path | None = None,
    world: str | None = None,
    on_round: OnRound | None = None,
) -> LoopResult:
    """The closed loop on a scenario of a registered world (by default the world that ships it;
    a household scenario value or file: the household). ``llm``: a backend, a function of the
    session, or a spec string; ``config``: a :class:`LoopConfig` (or plain settings)."""
    if world is None:
        world = world_of(scenario) if isinstance(scenario, str) else "household"
    backend = llm_for(llm, None, world) if isinstance(llm, str) else llm
    options = getattr(config, "options", None)
    return run(load_world(world), scenario, backend, config, options, out, on_round)


__all__ = [
    "ORACLE",
    "ORACLES",
    "ROBOTS",
    "WORLDS",
    "LoopConfig",
    "llm_for",
    "load_world",
    "oracle_for",
    "robot_command",
    "run_loop",
    "world_of",
]
