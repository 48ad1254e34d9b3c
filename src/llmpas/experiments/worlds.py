"""How an experiment runs the closed loop on a registered world (:mod:`llmpas.system.catalog`, the
product's registry, finds the worlds, their oracles and the ``--llm`` specs)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from llmpas.reasoning.llm import LLM
from llmpas.reasoning.truth_oracle import ORACLE
from llmpas.system import LLMFor, LoopResult, LoopSettings, OnRound, run
from llmpas.system.catalog import file_world, llm_for, load_world, world_of
from llmpas.worlds.api import RunOptions


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
        reader = file_world()
        world = world_of(scenario) if isinstance(scenario, str) else reader.name if reader else ""
    backend = llm_for(llm, None, world) if isinstance(llm, str) else llm
    options = getattr(config, "options", None)
    return run(load_world(world), scenario, backend, config, options, out, on_round)


__all__ = ["LoopConfig", "run_loop"]
