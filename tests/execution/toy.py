"""A tiny in-memory world (Robot + Perception) for executor tests: a cube somewhere on tables,
a gripper whose first grasps may slip."""

from __future__ import annotations

from typing import Any

from llmpas.execution.world import Detection, Observation, SkillResult


class ToyWorld:
    def __init__(self, cube_region: str, slips: int = 0) -> None:
        self.cube = cube_region
        self.slips = slips
        self.base: Any = "home"
        self.held: str | None = None
        self.calls: list[str] = []

    # Robot
    def move_base(self, conf: Any) -> SkillResult:
        self.calls.append(f"move_base {conf}")
        self.base = conf
        return SkillResult.success(f"at {conf}")

    def move_arm(self, target: Any) -> SkillResult:
        return SkillResult.success()

    def grasp(self, obj: str, grasp: Any) -> SkillResult:
        self.calls.append(f"grasp {obj} {grasp}")
        if self.slips:
            self.slips -= 1
            return SkillResult.failure("the object slipped")
        self.held = obj
        return SkillResult.success()

    def release(self, obj: str, pose: Any) -> SkillResult:
        self.held = None
        return SkillResult.success()

    def open(self, container: str) -> SkillResult:
        return SkillResult.success()

    def close(self, container: str) -> SkillResult:
        return SkillResult.success()

    def process(self, obj: str, appliance: str, how: str) -> SkillResult:
        return SkillResult.success()

    def base_conf(self) -> Any:
        return self.base

    def holding(self) -> str | None:
        return self.held

    # Perception
    def look(self, target: str | None = None) -> Observation:
        self.calls.append(f"look {target}")
        viewed = (target,) if target else ()
        found = tuple(Detection("cube", r, (0.0, 0.0)) for r in viewed if r == self.cube)
        return Observation(viewed, found)
