"""From a household plan to conditional subtrees: each action's atomic sub-actions, constraints
and conditional samplers.

Every subtree perceives first (it looks at the region it works in, and the belief is updated from
what is seen), then checks the plan step's precondition against the *believed* state — a literal
that perception made false is a constraint failure naming that literal — and then runs its
skills. A ``move_base`` step is merged into the action that follows it ("move-and-pick"): that
subtree chooses its own base pose by evaluating the deferred ``inverse-kinematics`` /
``sample-view`` stream on the perceived pose, and checks its drive with the deferred
``plan-base-motion``.

Exploration, in the order of the dimensions: where to look from (base poses facing the region),
which region of the furniture to look at, the grasp, the base pose to act from.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec, Values
from llmpas.execution.plan_builder import Recipe, failing_literal
from llmpas.execution.robot_protocols import Observation, Outcome, SkillResult, finish
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom, Not
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics
from llmpas.planning.result import Plan, PlanStep
from llmpas.worlds.household.household_problem import (
    PROPERTY_PREDICATE,
    Household,
    believe_at,
    believed_place,
    believed_placements,
)
from llmpas.worlds.household.household_values import ArmTarget, BaseConf, Grasp, Motion, Placement
from llmpas.worlds.household.state import PROPERTIES, VISIBLE
from llmpas.worlds.kitchen.belief import DETECTION
from llmpas.worlds.kitchen.kitchen_decomposition import OK, ExplorationConfig, KitchenBuilder

BASE_ACTIONS = (
    "pick",
    "place",
    "scan_table",
    "scan_drawer",
    "scan_container",
    "scan_cover",
    "open",
    "close",
)
FADES = frozenset(VISIBLE - {"cleaned", "cooked", "heated", "cooled"})
"""Visible states that a look without them shows gone (seen clean, dry, whole)."""


# --------------------------------------------------------------------------- belief updates


def observe(belief: Belief, house: Household, obs: Observation) -> None:
    """Update the belief from one look: detected objects and their visible properties.

    An object seen on the furniture where it was believed keeps its pose name and gets the seen
    position (Cartesian correction); one seen elsewhere gets a new pose."""
    belief.observations.append(obs)
    for d in obs.detections:
        if not isinstance(d.pose, Placement):
            continue
        _believe_seen(belief, house, d.obj, d.pose)
        region = house.layout.regions.get(d.pose.region)
        if region is not None and region.capacity == 2:  # seen in use: its limit matters
            belief.facts.add(Atom("double", (region.name,)))
        for prop, pred in PROPERTY_PREDICATE.items():
            atom = Atom(pred.lower(), (d.obj,))
            if prop in d.properties:
                belief.facts.add(atom)
            elif prop in FADES:
                belief.facts.discard(atom)  # seen clean, dry, whole


def furniture_of(house: Household, region: str) -> str:
    r = house.layout.regions.get(region)
    return r.furniture if r is not None else region


def _believe_seen(belief: Belief, house: Household, obj: str, place: Placement) -> None:
    if belief.matching("atgrasp", obj):
        return  # a held object is where the gripper is
    for a in belief.matching("atpose", obj):
        old = belief.values.get(a.args[1])
        same = isinstance(old, Placement) and furniture_of(house, old.region) == furniture_of(
            house, place.region
        )
        if same:
            p = a.args[1]
            belief.values[p] = place
            belief.replace(
                belief.matching("supported", obj, p), [Atom("supported", (obj, p, place.region))]
            )
            return
    believe_at(belief, obj, place)


# ------------------------------------------------------------------------------ the builder


@dataclass
class Builder(KitchenBuilder):
    """Builds the subtree specs of one plan, for one household and problem."""

    house: Household
    problem: Problem
    plan: Plan
    exploration: ExplorationConfig
    merged = BASE_ACTIONS

    def __post_init__(self) -> None:
        self.sem = Semantics(self.problem.domain, {}, {}, strict_costs=False)

    def otherwise(self, step: PlanStep) -> Recipe:
        return self.process(step)

    def same_place(self, belief: Belief, region: str, place: str) -> bool:
        """The same piece of furniture (a look covers all of a table top)."""
        return furniture_of(self.house, region) == furniture_of(self.house, place)

    def scan_inside(self, step: PlanStep) -> Recipe:
        return self.scan(step)

    # ---------------------------------------------------------------- shared pieces
    def _look(
        self,
        region_of: Callable[[Values, Context], str],
        name: str = "look",
        needs: tuple[str, ...] = (),
    ) -> SubAction:
        def run(v: Values, ctx: Context) -> SkillResult:
            region = region_of(v, ctx)
            obs = ctx.perception.look(region)
            observe(ctx.belief, self.house, obs)
            ctx.perceive("observed", obs)
            return SkillResult.success(f"looked at {region}")

        return SubAction(name, run, needs=needs)

    def _go(self, name: str, key: str) -> SubAction:
        def run(v: Values, ctx: Context) -> SkillResult:
            target: BaseConf = v[key]
            here = ctx.robot.base_conf()
            if isinstance(here, BaseConf) and here.distance(target) < 1e-3:
                return SkillResult.success("already there")
            motion = next(self._stream("plan-base-motion", (here, target)), None)
            waypoints = motion.waypoints[1:] if isinstance(motion, Motion) else (target,)
            result = OK
            for wp in waypoints:  # follow the deferred drive, way point by way point
                result = finish(ctx.robot.move_base(wp))
                if not result.ok:
                    break
            return result

        motion = Constraint(
            "BaseMotion",
            lambda v, ctx: self._drive_check(v[key], ctx),
            lambda v: Atom("basemotion", ("here", str(v.get(key)))),
            needs=(key,),
        )
        return SubAction(name, run, constraints=(motion,), needs=(key,))

    def _drive_check(self, target: BaseConf, ctx: Context) -> str | None:
        here = ctx.robot.base_conf()
        if not isinstance(here, BaseConf):
            return None
        out = next(self._stream("plan-base-motion", (here, target)), None)
        return None if out is not None else f"no collision-free drive to {target}"

    def _arm(self, name: str, where: Callable[[Values], Placement], phase: str) -> SubAction:
        def run(v: Values, ctx: Context) -> Outcome:
            p = where(v)
            region = self.house.layout.regions.get(p.region)
            z = region.height if region is not None else 0.8
            return ctx.robot.move_arm(ArmTarget(p.x, p.y, z, v["grasp"], phase))

        reach = Constraint(
            "Kin",
            lambda v, ctx: self._reach_check(where(v), v["base"]),
            lambda v: Atom("kin", ("arm", str(where(v)), str(v.get("grasp")))),
            needs=("grasp", "base"),
        )
        return SubAction(name, run, constraints=(reach,), needs=("grasp", "base"))

    def _approach(self, where: Callable[[Values], Placement]) -> tuple[SubAction, ...]:
        """Drive to the sampled base, pre-approach above the target, approach it."""
        return (
            self._go("pre_approach_base", "base"),
            self._arm("pre_approach", where, "pre"),
            self._arm("approach", where, "at"),
        )

    def _reach_check(self, p: Placement, base: BaseConf) -> str | None:
        d = ((p.x - base.x) ** 2 + (p.y - base.y) ** 2) ** 0.5
        return None if d <= self.house.layout.reach else f"{p} is {d:.2f} m from the base"

    # ---------------------------------------------------------------- recipes
    def _locate(self, obj: str, region: str) -> Recipe:
        furniture = furniture_of(self.house, region)
        layout = self.house.layout
        # the other parts of the same table top are in view too; a container (one drawer of
        # the cabinet) shows only its own inside, and only when it is open
        siblings = [region] + [
            r.name
            for r in layout.regions_of(furniture)
            if r.name != region and not r.openable and not layout.regions[region].openable
        ]

        seen_at: list[Placement] = []  # where this subtree has seen the object

        def views(v: Values) -> Iterator[str]:
            yield region
            for other in siblings[1:]:
                if not seen_at:  # once seen, a failure later on is not for want of looking
                    yield other

        def visible(v: Values, ctx: Context) -> str | None:
            view = v["view"]
            r = layout.regions.get(view)
            if r is None or not r.openable or view in v["observed"].viewed:
                return None
            ctx.belief.facts.discard(Atom("open", (view,)))  # seen closed
            return f"{view} is closed: nothing inside it could be seen"

        def detected(v: Values, ctx: Context) -> str | None:
            d = v["observed"].find(obj)
            where = getattr(d.pose, "region", "") if d is not None else ""
            if d is None:
                return f"{obj} not seen when looking at {v['view']}"
            if furniture_of(self.house, where) != furniture:
                return f"{obj} seen in {where}, not on {furniture}"
            seen_at.append(d.pose)
            ctx.perceive("detected", d.pose)
            return None

        found = Constraint(
            DETECTION, detected, lambda v: Atom("on", (obj, region)), needs=("view_base", "view")
        )
        dims = (
            self._view_bases(lambda v: self._holder_region(region)),
            Dimension("view", views, budget=len(siblings)),
        )
        seen = Constraint("Visible", visible, lambda v: Atom("open", (v["view"],)), needs=("view",))
        subs = (
            self._go("go_look", "view_base"),
            self._look(lambda v, c: v["view"], needs=("view",)),
            SubAction("locate", lambda v, c: OK, constraints=(seen, found)),
        )
        return dims, subs

    def pick(self, step: PlanStep) -> Recipe:
        obj, region = step.args[0], step.args[2]
        dims, subs = self._locate(obj, region)
        kinds = ["top"] if self.house.objects[obj].cover else ["top", "forward"]
        return dims + self._reach_dims(obj, lambda v: v["detected"], kinds), (
            *subs,
            self._check(step),
            *self._approach(lambda v: v["detected"]),
            self._grasp(obj, culprits=("grasp",)),
        )

    def place(self, step: PlanStep) -> Recipe:
        obj, p, region = step.args[0], step.args[1], step.args[2]
        holder = region if region in self.house.objects else None  # into a bowl
        planned = self.plan.objects.get(p) or self.problem.objects.get(p)

        def where(v: Values, ctx: Context) -> str:
            at = believed_place(ctx.belief, holder) if holder else None
            return at.region if at is not None else self._holder_region(region)

        def find_spot(v: Values, ctx: Context) -> str | None:
            if holder is None:
                ctx.perceive("spot", planned)  # CFree may choose another
                return None
            at = believed_place(ctx.belief, holder)
            if at is None:
                return f"{holder} is nowhere the robot knows"
            ctx.perceive("spot", Placement(holder, at.x, at.y))
            return None

        spot = Constraint("Located", find_spot, lambda v: Atom("region", (region,)))
        mistaken: dict[str, str] = {}

        def release(v: Values, c: Context) -> SkillResult:
            result = finish(c.robot.release(obj, v["spot"]))
            if not result.ok and result.data.get("reason") == "not_held":
                held = c.robot.holding()
                if held is not None and held != obj and held in self.house.objects:
                    self._mistook(c.belief, obj, held)  # a lookalike was picked up
                    mistaken["held"] = held
            return result

        def released_atom(v: Values) -> Atom:
            return Atom("holding", (obj,)) if mistaken else Atom("on", (obj, region))

        released = Constraint("Released", lambda v, c: None, released_atom, needs=("base",))
        dims: tuple[Dimension, ...] = (self._view_bases(lambda v: self._holder_region(region)),)
        extra = [spot]
        if holder is None and isinstance(planned, Placement):
            extra.append(self._clear(obj, p, planned))
        return dims + self._reach_dims(obj, lambda v: v["spot"], ["top"]), (
            self._go("go_look", "view_base"),
            self._look(where),
            self._check(step, *extra),
            *self._approach(lambda v: v["spot"]),
            SubAction("release", release, needs=("base",), on_failure=released),
        )

    def _clear(self, obj: str, pose: str, planned: Placement) -> Constraint:
        """Where to put ``obj`` down, clear of every object the robot believes somewhere (seen
        during this execution too): the planned placement, else one sampled in its region (a
        spot taken by what the robot did not know of is resampled, not only the base). The
        spot's collision facts (``CFree``) with the others enter the belief, so that the
        precondition ``(not (UnsafePose obj pose))`` reads them; a resampled spot becomes the
        value of the plan's pose name."""

        def candidates() -> Iterator[Placement]:
            yield planned
            others = self._stream("sample-pose", (obj, planned.region))
            for other in itertools.islice(others, self.exploration.spots):
                if isinstance(other, Placement) and other != planned:
                    yield other

        def check(v: Values, ctx: Context) -> str | None:
            for at in candidates():
                facts = collision_facts(self.house, ctx.belief, obj, pose, at)
                if facts is None:
                    continue
                if at != planned:
                    ctx.belief.values[pose] = at
                    ctx.belief.facts |= {
                        Atom("pose", (obj, pose)),
                        Atom("supported", (obj, pose, at.region)),
                    }
                ctx.belief.facts |= facts
                ctx.perceive("spot", at)
                return None
            return f"no free spot for {obj} on {planned.region}: what the robot sees is in the way"

        return Constraint("CFree", check, lambda v: Not(Atom("unsafepose", (obj, pose))))

    def _mistook(self, belief: Belief, obj: str, held: str) -> None:
        """The hand holds ``held``, not ``obj``: the grasp is ``held``'s, and where ``obj`` is
        is unknown."""
        grasps = belief.matching("atgrasp", obj)
        belief.replace(
            [*grasps, *belief.matching("grasp", obj)],
            [Atom(a.predicate, (held, a.args[1])) for a in grasps]
            + [Atom("grasp", (held, a.args[1])) for a in grasps],
        )
        believe_at(belief, held, None)
        believe_at(belief, obj, None)

    def _holder_region(self, region: str) -> str:
        """The layout region to look at: the region itself, or where a receptacle object stood
        in the plan's initial state."""
        if region in self.house.layout.regions:
            return region
        for a in self.problem.init:
            if a.predicate == "atpose" and a.args[0] == region:
                value = self.problem.objects.get(a.args[1])
                if isinstance(value, Placement):
                    return value.region
        return region

    def scan(self, step: PlanStep) -> Recipe:
        region = step.args[0]
        check = None
        if step.action == "scan_container":  # (searched R) is the goal's, not the belief's
            pre = self._precondition(step)
            target = Atom("searched", (region,))

            def searched(v: Values, ctx: Context) -> str | None:
                added = target not in ctx.belief.facts
                ctx.belief.facts.add(target)
                try:
                    return pre.check(v, ctx)
                finally:
                    if added:
                        ctx.belief.facts.discard(target)

            check = SubAction(
                "check", lambda v, c: OK, constraints=(Constraint(pre.name, searched, pre.atom),)
            )
        return self._scan(step, check)

    def scan_cover(self, step: PlanStep) -> Recipe:
        cover, region = step.args[0], step.args[2]
        dims, subs = self._locate(cover, region)

        def put_bases(v: Values) -> Iterator[BaseConf]:
            yield from self._stream("inverse-kinematics", (cover, v["beside"], v["grasp"]))

        put_base = Dimension(
            "put_base", put_bases, budget=self.exploration.base_samples, describe=str
        )
        lower = Constraint(
            "Kin",
            lambda v, ctx: self._reach_check(v["beside"], v["put_base"]),
            lambda v: Atom("kin", ("arm", str(v.get("beside")), "top-grasp")),
            needs=("put_base",),
        )
        return (*dims, *self._reach_dims(cover, lambda v: v["detected"], ["top"]), put_base), (
            *subs,
            self._go("pre_approach_base", "base"),
            self._arm("approach", lambda v: v["detected"], "at"),
            SubAction("lift", lambda v, c: c.robot.grasp(cover, v["grasp"]), needs=("grasp",)),
            self._arm("raise", lambda v: v["detected"], "pre"),
            self._look(lambda v, c: region, name="look_under"),
            SubAction("choose_spot", lambda v, c: self._beside(cover, v["detected"], c)),
            self._go("put_base", "put_base"),
            SubAction(
                "lower",
                lambda v, c: c.robot.move_arm(self._target(v["beside"], v["grasp"], "at")),
                constraints=(lower,),
                needs=("put_base",),
            ),
            SubAction("put_down", lambda v, c: self._put_down(cover, v["beside"], c)),
        )

    def _target(self, p: Placement, grasp: Grasp, phase: str) -> ArmTarget:
        region = self.house.layout.regions.get(p.region)
        return ArmTarget(p.x, p.y, region.height if region else 0.8, grasp, phase)

    def _beside(self, cover: str, at: Placement, ctx: Context) -> SkillResult:
        """A free spot for the cover on the same furniture, clear of what it covered (the robot
        then drives where it can reach it)."""
        radius = self.house.objects[cover].radius
        others = [
            (believed_place(ctx.belief, o), spec.radius)
            for o, spec in self.house.objects.items()
            if o != cover
        ]
        furniture = furniture_of(self.house, at.region)
        regions = [r.name for r in self.house.layout.regions_of(furniture) if r.kind == "surface"]
        for region in [at.region] + [r for r in regions if r != at.region]:
            for p in itertools.islice(self._stream("sample-pose", (cover, region)), 40):
                if all(
                    q is None or q.region != p.region or p.distance(q) >= radius + r + 0.02
                    for q, r in others
                ):
                    ctx.perceive("beside", p)
                    return SkillResult.success(f"put the {cover} down at {p}")
        return SkillResult.failure(f"no free spot for the {cover} on {furniture}")

    def _put_down(self, cover: str, spot: Placement, ctx: Context) -> SkillResult:
        result = finish(ctx.robot.release(cover, spot))
        if result.ok:
            for a in ctx.belief.matching("atpose", cover):
                ctx.belief.values[a.args[1]] = spot  # the cover now stands beside
        return result

    def open_close(self, step: PlanStep) -> Recipe:
        region = step.args[0]
        opening = step.action == "open"
        revealed: dict[str, Atom] = {}

        def run(v: Values, c: Context) -> SkillResult:
            result = finish(c.robot.open(region) if opening else c.robot.close(region))
            reason = result.data.get("reason")
            if result.ok or reason not in ("jammed", "obstructed"):
                return result
            if reason == "jammed":  # the reason enters the belief: the planner avoids it
                revealed["fact"] = Atom("jammed", (region,))
                c.belief.replace((), [revealed["fact"]])
            else:  # look at the floor in front of it: what blocks it is then believed there
                revealed["fact"] = Atom("obstructed", (region,))
                for r in self.house.layout.regions:
                    if self.house.layout.on_floor(r):
                        observe(c.belief, self.house, c.perception.look(r))
            return result

        def failed(v: Values) -> Atom | Not:  # as a skill failure, unless a reason is known
            fact = revealed.get("fact")
            return Not(fact) if fact is not None else Atom(step.action, ())

        blocked = Constraint(
            f"{step.action}-succeeds", lambda v, c: None, failed, needs=("view_base",)
        )
        return (self._view_bases(lambda v: region),), (
            self._go("go_to", "view_base"),
            SubAction(step.action, run, needs=("view_base",), on_failure=blocked),
            self._look(lambda v, c: region),
        )

    def process(self, step: PlanStep) -> Recipe:
        obj, region = step.args[0], step.args[1]
        revealed: dict[str, Atom] = {}

        def run(v: Values, c: Context) -> SkillResult:
            result = finish(c.robot.process(obj, region, step.action))
            prop = result.data.get("reason")
            if not result.ok and prop in PROPERTIES:  # e.g. it will not cool: it is dirty
                revealed["fact"] = Atom(str(prop), (obj,))
                c.belief.replace((), [revealed["fact"]])
            return result

        def failed(v: Values) -> Atom | Not:
            fact = revealed.get("fact")
            return Not(fact) if fact is not None else Atom(step.action, ())

        blocked = Constraint(f"{step.action}-succeeds", lambda v, c: None, failed)
        return (), (
            self._look(lambda v, c: region, name="inspect"),
            self._check(step),
            SubAction(step.action, run, on_failure=blocked),
        )


def collision_facts(
    house: Household, belief: Belief, obj: str, pose: str, at: Placement
) -> set[Atom] | None:
    """``(cfree obj pose o2 p2)`` for every other object ``o2`` believed at a pose ``p2`` (as
    the ``test-cfree`` stream decides: another region, or footprints apart); None when ``at``
    overlaps one of them."""
    out: set[Atom] = set()
    radius = house.objects[obj].radius
    for o2, p2, there, spec in believed_placements(house, belief):
        if o2 == obj:
            continue
        if there.region == at.region and at.distance(there) < radius + spec.radius:
            return None
        out.add(Atom("cfree", (obj, pose, o2, p2)))
    return out


def build_specs(
    house: Household, problem: Problem, plan: Plan, config: ExplorationConfig | None = None
) -> list[SubtreeSpec]:
    """The conditional subtrees of a household plan, in order."""
    return Builder(house, problem, plan, config or ExplorationConfig()).specs()


__all__ = [
    "ExplorationConfig",
    "build_specs",
    "collision_facts",
    "failing_literal",
    "furniture_of",
    "observe",
]
