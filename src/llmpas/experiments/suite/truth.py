"""Whether a task's success condition (``[judge] success``) holds on the simulator's TRUE
state."""

from __future__ import annotations

import logging

from llmpas.language.sexpr import SExpr, SList, parse_all
from llmpas.worlds.household.state import TrueState

log = logging.getLogger(__name__)


def holds_in_truth(formula: str, truth: TrueState) -> bool:
    """Whether the success formula holds on the simulator's true state."""
    exprs = parse_all(formula, "judge.success")
    if len(exprs) != 1 or not isinstance(exprs[0], SList):
        raise ValueError(f"not one formula: {formula!r}")
    return _holds(exprs[0], truth)


def _holds(e: SExpr, truth: TrueState) -> bool:
    assert isinstance(e, SList)
    head = e.head()
    if head == "and":
        return all(_holds(i, truth) for i in e.items[1:])
    if head == "or":
        return any(_holds(i, truth) for i in e.items[1:])
    if head == "not":
        return not _holds(e.items[1], truth)
    args = [str(a) for a in e.items[1:]]
    if head == "on":
        obj, region = args
        p = truth.placements.get(obj)
        return obj != truth.held and p is not None and p.region == region
    if head == "holding":
        return truth.held == args[0]
    if head == "open":
        return bool(truth.open.get(args[0], False))
    return head in truth.properties.get(args[0], set())
