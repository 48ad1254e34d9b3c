"""What the kitchen domain's predicates say about where an object is, read from and written to a
robot's :class:`~llmpas.execution.context.Belief` (the executor's belief speaks no domain)."""

from __future__ import annotations

from typing import Any, TypeVar

from llmpas.execution.context import Belief
from llmpas.language.logic import Atom

T = TypeVar("T")

WHEREABOUTS = ("atpose", "supported", "pose")  # the facts that say where an object rests
DETECTION = "Detected"  # the constraint a look that does not find the object fails


def rests_at(belief: Belief, obj: str, pose: Any | None) -> None:
    """Believe ``obj`` rests at ``pose`` (a value with a ``region``; None: whereabouts unknown):
    its ``pose``, ``atpose`` and ``supported`` facts are replaced."""
    belief.facts -= {a for a in belief.facts if a.predicate in WHEREABOUTS and a.args[0] == obj}
    if pose is None:
        return
    p = belief.name(f"p_{obj}", pose)
    belief.facts |= {
        Atom("pose", (obj, p)),
        Atom("atpose", (obj, p)),
        Atom("supported", (obj, p, pose.region)),
    }


def pose_of(belief: Belief, obj: str, kind: type[T]) -> T | None:
    """The value of the pose ``obj`` is believed at, if it is a ``kind``."""
    for a in belief.facts:
        if a.predicate == "atpose" and a.args[0] == obj:
            value = belief.values.get(a.args[1])
            return value if isinstance(value, kind) else None
    return None


def believed_lost(belief: Belief, obj: str, place: object | None) -> bool:
    """An object is lost when the belief has no place for it and the robot does not hold it."""
    return place is None and not belief.matching("atgrasp", obj)


__all__ = ["DETECTION", "WHEREABOUTS", "believed_lost", "pose_of", "rests_at"]
