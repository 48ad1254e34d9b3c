"""How the loop reasons, in every world (:class:`LoopSettings`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from llmpas.reasoning.assists import Assists
from llmpas.reasoning.methods import MethodConfig
from llmpas.system.sweep import SweepBudget


@dataclass(frozen=True)
class LoopSettings:
    """How the loop reasons, in every world (:class:`~llmpas.worlds.api.RunOptions`: how the
    world runs)."""

    method: MethodConfig = field(default_factory=MethodConfig)
    max_rounds: int = 3  # LLM consultations at most
    deadline: float | None = None  # seconds for the whole loop (checked between its steps)
    assists: Assists = field(default_factory=Assists)  # what the loop does for the LLM
    # the task's intent (a task file's ``[judge] success``, PDDL): what ends the loop, so that
    # an equivalent object can satisfy it; None: the task goal itself
    success: str | None = None
    # how far one object-loss consultation's search may go (places, actions: counts)
    sweep: SweepBudget = field(default_factory=SweepBudget)

    def __post_init__(self) -> None:
        if self.success is not None and not self.success.strip():
            raise ValueError("success must be a PDDL formula, got an empty text")
        if self.max_rounds < 0:
            raise ValueError(f"max_rounds must be >= 0, got {self.max_rounds}")
        if self.deadline is not None and not (math.isfinite(self.deadline) and self.deadline > 0):
            raise ValueError(f"deadline must be a positive number of seconds, got {self.deadline}")


__all__ = ["LoopSettings", "SweepBudget"]
