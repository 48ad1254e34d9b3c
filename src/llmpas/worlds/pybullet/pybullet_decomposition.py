"""From a plan over the household domain to CSubBT specs for the PyBullet world.

As in the household world, a ``move_base`` step is merged into the action that follows it
("move-and-pick"): the subtree searches for the object (drives to base poses facing the table and
looks with the mast camera — the search behaviour), checks the step's precondition against the
believed state, chooses its grasp and base pose with the deferred ``inverse-kinematics`` stream
evaluated on the *detected* pose, pre-approaches, corrects the detected pose with the wrist camera,
approaches and grasps (or releases).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec, Values
from llmpas.execution.plan_builder import Recipe
from llmpas.execution.robot_protocols import Observation, Outcome, SkillResult
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics
from llmpas.planning.result import Plan, PlanStep
from llmpas.worlds.kitchen.belief import DETECTION
from llmpas.worlds.kitchen.kitchen_decomposition import OK, KitchenBuilder
from llmpas.worlds.kitchen.kitchen_decomposition import ExplorationConfig as KitchenExploration
from llmpas.worlds.pybullet.pybullet_problem import believe_at, believed_pose
from llmpas.worlds.pybullet.pybullet_values import ArmGoal, BaseConf, BasePath, ObjectPose
from llmpas.worlds.pybullet.scene import RIM_MARGIN, TABLE_TOP, SceneConfig

MERGED = ("pick", "place", "scan_table")


@dataclass(frozen=True)
class ExplorationConfig(KitchenExploration):
    """The kitchen budgets, and how the PyBullet robot releases and searches."""

    drop: float = 0.02  # release this far above the resting height
    # how to look for an object at each base pose of the search: the mast, then the raised arm
    cameras: tuple[str, ...] = ("mast", "arm")

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.cameras or not set(self.cameras) <= {"mast", "arm"}:
            raise ValueError(f"cameras must be a non-empty subset of mast/arm: {self.cameras}")
        if self.drop < 0:
            raise ValueError("drop must be >= 0")


def table_of(config: SceneConfig, belief: Belief, region: str) -> str:
    """The table a region is on: itself, or the table a bowl is believed on."""
    if region in {t.name for t in config.tables}:
        return region
    at = believed_pose(belief, region)
    return at.region if at is not None and at.region != region else region


def observe(belief: Belief, config: SceneConfig, obs: Observation) -> None:
    """Update the belief from one look: an object seen where it was believed keeps its pose name
    with the seen position; one seen elsewhere gets a new pose."""
    belief.observations.append(obs)
    for d in obs.detections:
        if not isinstance(d.pose, ObjectPose) or belief.matching("atgrasp", d.obj):
            continue
        old = believed_pose(belief, d.obj)
        if old is not None and old.region == d.pose.region:
            for a in belief.matching("atpose", d.obj):
                belief.values[a.args[1]] = d.pose
            continue
        believe_at(belief, d.obj, d.pose)


def covering(
    config: SceneConfig,
    obs: Observation | None,
    spot: ObjectPose,
    rest: float,
    ignore: tuple[str, ...] = (),
    width: float = 0.0,
) -> str | None:
    """An object the look saw lying over ``spot`` higher than ``rest``, the z a placed object's
    bottom would rest at (a lid on a bowl's rim over the bowl's inside): its footprint overlaps
    that of the object to place there (``width`` wide), so the hand cannot put it down. Read from
    the detections alone: the belief has no fact for it (such an object is on the table under
    it, not in the bowl)."""
    known = {o.name: o for o in config.objects}
    for d in obs.detections if obs is not None else ():
        o = known.get(d.obj)
        if o is None or d.obj in ignore or not isinstance(d.pose, ObjectPose):
            continue
        half = (o.size + width) / 2
        bottom = d.pose.z - o.origin_height
        over = abs(d.pose.x - spot.x) <= half and abs(d.pose.y - spot.y) <= half
        if over and bottom > rest + RIM_MARGIN:
            return d.obj
    return None


class Builder(KitchenBuilder):
    merged = MERGED
    fit_grasp_budget = True
    exploration: ExplorationConfig

    def __init__(
        self, config: SceneConfig, problem: Problem, plan: Plan, exploration: ExplorationConfig
    ) -> None:
        self.config = config
        self.problem = problem
        self.plan = plan
        self.exploration = exploration
        self.sem = Semantics(problem.domain, {}, {}, strict_costs=False)

    def after_step(self, step: PlanStep, v: Values, ctx: Context) -> None:
        """A placed object rests where it was released, a little below the spot."""
        if step.action == "place" and isinstance(v.get("spot"), ObjectPose):
            spot: ObjectPose = v["spot"]
            rest = ObjectPose(spot.region, spot.x, spot.y, spot.z - self.exploration.drop)
            ctx.belief.values[step.args[1]] = rest

    def same_place(self, belief: Belief, region: str, place: str) -> bool:
        """The same table (a bowl: the table it is believed on)."""
        return table_of(self.config, belief, region) == table_of(self.config, belief, place)

    def otherwise(self, step: PlanStep) -> Recipe:
        def run(v: Values, c: Context) -> SkillResult:
            return SkillResult.failure(f"{step.action} is not supported in the PyBullet world")

        return (), (SubAction(step.action, run),)

    # ------------------------------------------------------------------ pieces

    def _go(self, name: str, key: str) -> SubAction:
        def plan(v: Values, ctx: Context) -> BasePath | None:
            here = ctx.robot.base_conf()
            target: BaseConf = v[key]
            return next(self._stream("plan-base-motion", (here, target)), None)

        def check(v: Values, ctx: Context) -> str | None:
            here = ctx.robot.base_conf()
            if isinstance(here, BaseConf) and here.distance(v[key]) < 1e-3:
                return None
            path = plan(v, ctx)
            if path is None:
                return f"no collision-free drive to {v[key]}"
            ctx.perceive(f"{name}_path", path)
            return None

        def run(v: Values, ctx: Context) -> Outcome:
            here = ctx.robot.base_conf()
            if isinstance(here, BaseConf) and here.distance(v[key]) < 1e-3:
                return SkillResult.success("already there")
            path = v.get(f"{name}_path")
            drive = getattr(ctx.robot, "drive", None)
            if isinstance(path, BasePath) and drive is not None:
                result: SkillResult = drive(path)
                return result
            return ctx.robot.move_base(v[key])

        motion = Constraint(
            "BaseMotion",
            check,
            lambda v: Atom("basemotion", ("here", str(v.get(key)))),
            needs=(key,),
        )
        return SubAction(name, run, constraints=(motion,), needs=(key,))

    def _look(self, region: Callable[[Values, Context], str], search: bool = False) -> SubAction:
        """Look at the region with the mast camera, or (``search``: the ``camera`` dimension
        says ``arm``) with the wrist camera raised on the arm."""

        def run(v: Values, ctx: Context) -> SkillResult:
            r = region(v, ctx)
            arm_look = getattr(ctx.robot, "look_with_arm", None)
            if search and v.get("camera") == "arm" and arm_look is not None:
                obs: Observation = arm_look(r)
            else:
                obs = ctx.perception.look(r)
            observe(ctx.belief, self.config, obs)
            ctx.perceive("observed", obs)
            return SkillResult.success(f"looked at {r}: {len(obs.detections)} detections")

        needs = ("view_base", "camera") if search else ("view_base",)
        return SubAction("look", run, needs=needs)

    def _arm(
        self, name: str, where: Callable[[Values], ObjectPose], phase: str, obj: str
    ) -> SubAction:
        def run(v: Values, ctx: Context) -> Outcome:
            return ctx.robot.move_arm(ArmGoal(where(v), v["grasp"], phase, obj))

        reach = Constraint(
            "Kin",
            lambda v, c: None,
            lambda v: Atom("kin", ("arm", str(where(v)), str(v.get("grasp")))),
            needs=("grasp", "base"),
        )
        return SubAction(name, run, needs=("grasp", "base"), on_failure=reach)

    # ------------------------------------------------------------------ recipes

    def pick(self, step: PlanStep) -> Recipe:
        obj, region = step.args[0], step.args[2]

        def look_region(v: Values, ctx: Context) -> str:
            return table_of(self.config, ctx.belief, region)

        def detected(v: Values, ctx: Context) -> str | None:
            d = v["observed"].find(obj)
            table = table_of(self.config, ctx.belief, region)
            if d is None:
                return f"{obj} not detected on {table}"
            seen = table_of(self.config, ctx.belief, d.region)
            if seen != table:
                return f"{obj} seen on {seen}, not on {table}"
            ctx.perceive("detected", d.pose)
            return None

        def correct(v: Values, ctx: Context) -> SkillResult:
            fresh = getattr(ctx.robot, "wrist_detect", None)
            pose = fresh(obj) if fresh is not None else None
            if isinstance(pose, ObjectPose):
                ctx.perceive("detected", pose)
                return SkillResult.success(f"corrected to {pose}")
            return SkillResult.success("not seen by the wrist camera; keeping the pose")

        found = Constraint(
            DETECTION,
            detected,
            lambda v: Atom("on", (obj, region)),
            needs=("view_base", "camera"),
        )
        cameras = Dimension(
            "camera",
            lambda v: list(self.exploration.cameras),
            budget=len(self.exploration.cameras),
            describe=str,
        )
        dims = (
            self._view_bases(lambda v: region),
            cameras,
            *self._reach_dims(obj, lambda v: v["detected"], ["top", "forward"]),
        )
        return dims, (
            self._go("go_look", "view_base"),
            self._look(look_region, search=True),
            SubAction("locate", lambda v, c: OK, constraints=(found,)),
            self._check(step),
            self._go("pre_approach_base", "base"),
            self._arm("pre_approach", lambda v: v["detected"], "pre", obj),
            SubAction("correct", correct),
            self._arm("approach", lambda v: v["detected"], "at", obj),
            self._grasp(obj),
        )

    def place(self, step: PlanStep) -> Recipe:
        obj, p, region = step.args[0], step.args[1], step.args[2]
        bowls = {o.name for o in self.config.objects if o.kind == "bowl"}
        planned = self.plan.objects.get(p) or self.problem.objects.get(p)
        height = self.config.obj(obj).height

        def look_region(v: Values, ctx: Context) -> str:
            return table_of(self.config, ctx.belief, region)

        def find_spot(v: Values, ctx: Context) -> str | None:
            if region in bowls:
                at = believed_pose(ctx.belief, region)
                if at is None:
                    return f"{region} is nowhere the robot knows"
                z = TABLE_TOP + 0.01 + height / 2 + self.exploration.drop
                ctx.perceive("spot", ObjectPose(region, at.x, at.y, z))
                return None
            if not isinstance(planned, ObjectPose):
                return f"no placement for {obj} on {region}"
            ctx.perceive(
                "spot", ObjectPose(region, planned.x, planned.y, planned.z + self.exploration.drop)
            )
            return None

        def uncovered(v: Values, ctx: Context) -> str | None:
            rest = v["spot"].z - self.exploration.drop - height / 2  # where its bottom goes
            width = self.config.obj(obj).size
            d = covering(self.config, v.get("observed"), v["spot"], rest, (obj, region), width)
            return None if d is None else f"{d} lies over {region}, covering it"

        spot = Constraint("Located", find_spot, lambda v: Atom("region", (region,)))
        clear = Constraint(
            "Uncovered", uncovered, lambda v: Atom("accessible", (region,)), needs=("view_base",)
        )
        released = Constraint(
            "Released", lambda v, c: None, lambda v: Atom("on", (obj, region)), needs=("base",)
        )
        dims = (
            self._view_bases(lambda v: region),
            *self._reach_dims(obj, lambda v: v["spot"], ["top"]),
        )
        return dims, (
            self._go("go_look", "view_base"),
            self._look(look_region),
            self._check(step, spot, clear),
            self._go("pre_approach_base", "base"),
            self._arm("pre_approach", lambda v: v["spot"], "pre", obj),
            self._arm("approach", lambda v: v["spot"], "at", obj),
            SubAction(
                "release",
                lambda v, c: c.robot.release(obj, v["spot"]),
                needs=("base",),
                on_failure=released,
            ),
        )


def build_specs(
    config: SceneConfig, problem: Problem, plan: Plan, exploration: ExplorationConfig | None = None
) -> list[SubtreeSpec]:
    return Builder(config, problem, plan, exploration or ExplorationConfig()).specs()
