"""What the kitchen worlds' sessions share: the planner's default, the search model's words and
its "lost" test, and the session properties read from the scenario and the context."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.context import Belief, Context
from llmpas.planning import PlannerConfig
from llmpas.worlds.kitchen.belief import DETECTION, believed_lost, pose_of

#: Counted limits decide the verdict; the time limits are safety nets that do not fire under
#: load, so the same task, seed and LLM give the same run on any machine (issue #35, item 5).
PLANNER = PlannerConfig.validation()


@dataclass(frozen=True)
class KitchenSearch:
    """Searching in a kitchen world (a :class:`llmpas.worlds.api.SearchModel`): ``(scanned P)``
    looks at one of the places ``where``, an object rests ``on`` a place, a failed look fails
    ``Detected`` and ``looked`` tells where it looked. An object the world ``known`` is lost when
    the belief has no ``pose_type`` value of where it rests and the robot does not hold it."""

    belief: Belief
    where: tuple[str, ...]
    known: frozenset[str]
    pose_type: type
    looked: Callable[[AnomalyReport], tuple[str, ...]]
    predicate: str = "scanned"
    location: str = "on"
    detection: str = DETECTION

    def __post_init__(self) -> None:
        if not self.where:
            raise ValueError("a search needs at least one place to look at")

    def places(self) -> tuple[str, ...]:
        return self.where

    def looked_at(self, report: AnomalyReport) -> tuple[str, ...]:
        return self.looked(report)

    def lost(self, obj: str) -> bool:
        place = pose_of(self.belief, obj, self.pose_type)
        return obj in self.known and believed_lost(self.belief, obj, place)


class KitchenScenario(Protocol):
    @property
    def name(self) -> str: ...

    @property
    def goal(self) -> str: ...


class KitchenSession:
    """A session's name and task (its scenario's) and belief (its context's)."""

    scenario: KitchenScenario
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
