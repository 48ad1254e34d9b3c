"""What the kitchen worlds' sessions share: the planner's default, the search model's words and
its "lost" test, and the session properties read from the scenario and the context."""

from __future__ import annotations

from typing import Protocol

from llmpas.execution.context import Belief, Context
from llmpas.planning import PlannerConfig
from llmpas.worlds.api import believed_lost

PLANNER = PlannerConfig(max_time=60.0)


class KitchenSearch:
    """Searching in a kitchen world (a :class:`llmpas.worlds.api.SearchModel` with ``places``
    and ``looked_at`` of the world's own): ``(scanned P)`` looks at a place, an object rests
    ``on`` a place, a failed look fails ``Detected``. An object the world knows is lost when it
    is believed nowhere and not held."""

    predicate = "scanned"
    location = "on"
    detection = "Detected"
    belief: Belief
    pose_type: type = object  # the world's value of where an object rests

    def knows(self, obj: str) -> bool:
        raise NotImplementedError

    def lost(self, obj: str) -> bool:
        place = self.belief.pose_of(obj, self.pose_type)
        return self.knows(obj) and believed_lost(self.belief, obj, place)


class Scenario(Protocol):
    @property
    def name(self) -> str: ...

    @property
    def goal(self) -> str: ...


class KitchenSession:
    """A session's name and task (its scenario's) and belief (its context's)."""

    scenario: Scenario
    context: Context

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def task(self) -> str:
        return self.scenario.goal

    @property
    def belief(self) -> Belief:
        return self.context.belief


__all__ = ["PLANNER", "KitchenSearch", "KitchenSession"]
