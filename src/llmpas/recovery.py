"""Another name of :mod:`llmpas.system.recovery` (what the closed loop keeps from a recovery:
recovery goals kept true, and staged in the order the LLM wrote them)."""

from llmpas.system.recovery import (
    Stages,
    conjuncts,
    kept_goal,
    negation,
    out_of_order,
    reached_at,
)

__all__ = ["Stages", "conjuncts", "kept_goal", "negation", "out_of_order", "reached_at"]
