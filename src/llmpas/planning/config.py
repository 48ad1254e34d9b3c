"""Planner configuration: one frozen value instead of many keyword arguments."""

from __future__ import annotations

from dataclasses import dataclass

from llmpas.planning.result import Algorithm


@dataclass(frozen=True)
class PlannerConfig:
    """How to plan.

    ``defer``: when True, streams whose :class:`~llmpas.language.bindings.StreamInfo` says
    ``deferred`` are assumed satisfiable while planning and left for the executor; when False
    (nothing deferred: every stream computed; ``--no-defer``, formerly called "eager"), every
    stream is evaluated at planning time.

    ``share_placeholders``: when True, instances of a stream evaluated while planning share one
    placeholder per (stream, output, level), as in PDDLStream: far smaller tasks where a
    ``forall`` ranges over placeholders (``llmpas bench tamp``), but not complete: on the
    household's blocked-microwave task it exhausted every instance and reported a solvable task
    unsolvable. Off by default (one placeholder per instance).
    """

    algorithm: Algorithm = "focused"
    defer: bool = True
    max_time: float = 60.0
    max_iterations: int = 200
    max_level: int = 4  # how deep stream outputs may feed other streams in one optimistic pass
    search_time: float = 30.0  # per classical-planner call
    memory_mb: int = 4096
    seed: int = 0
    share_placeholders: bool = False
    search: str | None = None  # a Fast Downward search string (None: lazy greedy with FF)

    def __post_init__(self) -> None:
        if self.algorithm not in ("focused", "incremental"):
            raise ValueError(
                f"algorithm must be 'focused' or 'incremental', got {self.algorithm!r}"
            )
        if self.max_time <= 0 or self.search_time <= 0:
            raise ValueError("max_time and search_time must be > 0")
        if self.max_iterations < 1 or self.max_level < 1:
            raise ValueError("max_iterations and max_level must be >= 1")
        if self.memory_mb < 64:
            raise ValueError(f"memory_mb must be >= 64, got {self.memory_mb}")
