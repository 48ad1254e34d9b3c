"""A tiny in-memory world (Robot + Perception) for executor tests: a cube somewhere on tables,
a gripper whose first grasps may slip."""

from __future__ import annotations

from typing import Any

from llmpas.execution.context import Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec
from llmpas.execution.robot_protocols import Detection, Observation, SkillResult
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom

TABLE1 = ["t1a", "t1b", "t1c"]


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


def located(v: Any, ctx: Context) -> str | None:
    o = ctx.perception.look(v["region"])
    ctx.belief.observations.append(o)
    return None if o.find("cube") else f"cube not detected in {v['region']}"


def pick_spec(
    regions: list[str] = TABLE1,
    bases: tuple[str, ...] = ("q1", "q2"),
    max_samples: int = 40,
    label: str = "move-and-pick cube",
) -> SubtreeSpec:
    """A move-and-pick subtree over the toy world: base poses, table regions, grasps."""
    detected = Constraint(
        "Detected", located, lambda v: Atom("on", ("cube", "table1")), needs=("base", "region")
    )
    grasped = Constraint(
        "Grasped", lambda v, c: None, lambda v: Atom("holding", ("cube",)), needs=("grasp",)
    )
    subs = (
        SubAction("move_base", lambda v, c: c.robot.move_base(v["base"]), needs=("base",)),
        SubAction("locate", lambda v, c: SkillResult.success(), constraints=(detected,)),
        SubAction(
            "grasp",
            lambda v, c: c.robot.grasp("cube", v["grasp"]),
            needs=("grasp",),
            on_failure=grasped,
        ),
    )
    dims = (
        Dimension("base", lambda v: list(bases)),
        Dimension("region", lambda v: list(regions)),
        Dimension("grasp", lambda v: ["top", "forward"]),
    )
    return SubtreeSpec(
        label, (0, 1), "move-and-pick", ("cube",), {}, dims, subs, max_samples=max_samples
    )
