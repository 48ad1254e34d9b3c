"""Whether a task's success condition (``[judge] success``) holds on the simulator's TRUE
state."""

from __future__ import annotations

from llmpas.worlds.api import holds
from llmpas.worlds.household.state import TrueState, true_facts


def holds_in_truth(formula: str, truth: TrueState) -> bool:
    """Whether the success formula holds on the simulator's true state: the one truth judge
    (:func:`llmpas.worlds.api.holds`) over the true facts, as ``llmpas run`` judges a task."""
    return holds(formula, true_facts(truth))
