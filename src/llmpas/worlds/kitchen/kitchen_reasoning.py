"""What every kitchen world tells the reasoner alike: the program calls of the actions all of
them have, and how a believed object's whereabouts are said."""

from __future__ import annotations

from typing import Any

from llmpas.execution.context import Belief
from llmpas.reasoning.tables import Call

CALLS = {
    "pick": Call(("obj",), "holding", (0,)),
    "place": Call(("obj", "region"), "on", (0, 1)),
    "scan_table": Call(("region",), "scanned", (0,)),
}
"""The program calls of pick, place and scan_table (a world adds its own after them)."""


def whereabouts(belief: Belief, obj: str, place: Any, holder: str = "the robot") -> str:
    """``held by <holder>``, ``on <region>`` or ``location unknown``, as believed."""
    if belief.matching("atgrasp", obj):
        return f"held by {holder}"
    return f"on {place.region}" if place else "location unknown"


__all__ = ["CALLS", "whereabouts"]
