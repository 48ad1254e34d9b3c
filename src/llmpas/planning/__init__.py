"""llmpas.planning: stream-based TAMP planning on a classical planner (Fast Downward)."""

from llmpas.planning.config import PlannerConfig
from llmpas.planning.result import Plan, PlanResult, PlanStats, PlanStatus, PlanStep, StreamInstance
from llmpas.planning.tamp import solve

__all__ = [
    "Plan",
    "PlanResult",
    "PlanStats",
    "PlanStatus",
    "PlanStep",
    "PlannerConfig",
    "StreamInstance",
    "solve",
]
