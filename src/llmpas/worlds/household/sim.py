"""The household simulator: a :class:`~llmpas.execution.robot_protocols.Robot` and
:class:`~llmpas.execution.robot_protocols.Perception` over a hidden :class:`TrueState`.

The robot acts on the true state and sees it only through :meth:`HouseholdWorld.look` (noisy,
with misdetections) and through its skills' outcomes. Scenario events change the true state
behind its back, inside the skill call that triggers them.

Geometry: the base is a disc of ``layout.robot_radius``; the arm reaches ``layout.reach`` from
the TRUE base centre; arm targets and placements are world coordinates. Every random draw comes
from the generator given to the world, so a seeded generator replays an episode exactly.

Failed skills return a :class:`SkillResult` whose message says why and whose ``data["reason"]``
is a short code: ``blocked``, ``bad_value``, ``out_of_reach``, ``hand_full``, ``not_held``,
``arm_not_ready``, ``nothing_there``, ``closed``, ``covered``, ``slipped``, ``not_region``,
``occupied``, ``outside``, ``overlap``, ``not_openable``, ``cannot_process``, ``not_in``,
``open``, ``jammed``, ``obstructed``, ``broken``, ``wet``, ``crowded`` (another object is in an
appliance that processes one at a time, a house rule the domain does not model), and an object
state that blocks a process (``dirty``, ``hot``, ``cooked``, ``spilled``, and the states the
domain does not model, ``frozen``, ``greasy``, ``waxed``: see ``state.HIDDEN``). A detector
may take a lookalike for the object it resembles (``[[noise.confuse]]``); grasping what it saw
then takes the lookalike.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

from llmpas.execution.robot_protocols import Detection, Observation, SkillResult
from llmpas.worlds.household.household_values import ArmTarget, BaseConf, Grasp, Motion, Placement
from llmpas.worlds.household.layout import Layout, kitchen
from llmpas.worlds.household.scenario import Disturbance, Event, Scenario
from llmpas.worlds.household.state import (
    BLOCKING,
    HIDDEN_BLOCKING,
    ONE_AT_A_TIME,
    PROCESS_EFFECTS,
    PROCESS_REMOVES,
    VISIBLE,
    TrueState,
    base_collision,
    point_rect_distance,
    segment_rect_distance,
)

GRASP_TOLERANCE = 0.03
"""How far (m, plus the object's radius) the gripper may be from an object to grasp it, or from
a placement to release there."""

CONFUSED = 0.9
"""The confidence of a detection that took a lookalike for another object (below a true one's)."""

PATH_TOLERANCE = 0.005
"""How much closer than ``robot_radius`` (m) a drive may graze furniture (discretised planners)."""


@dataclass(frozen=True)
class LogEntry:
    """One line of the world's log: a skill call, a fired event or a disturbance."""

    kind: str  # "skill" | "event" | "disturbance"
    name: str  # the skill, the event type or the disturbance kind
    args: tuple[str, ...]
    ok: bool
    message: str
    reason: str = ""  # a failed skill's reason code (module docstring)

    def __str__(self) -> str:
        mark = "ok" if self.ok else "FAILED"
        return f"[{self.kind}] {self.name}({', '.join(self.args)}) {mark}: {self.message}"


def _fail(reason: str, message: str) -> SkillResult:
    return SkillResult.failure(message, reason=reason)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


class HouseholdWorld:
    """A simulated household built from a scenario; implements ``Robot`` and ``Perception``."""

    def __init__(self, layout: Layout, scenario: Scenario, rng: np.random.Generator) -> None:
        self.layout = layout
        self.scenario = scenario
        self.rng = rng
        self.truth: TrueState = scenario.initial_state(layout)
        self.log: list[LogEntry] = []
        self.arm_target: ArmTarget | None = None
        self.camera_heading: float = scenario.robot.theta
        self._commanded: BaseConf = scenario.robot
        self._successes: Counter[str] = Counter()
        self._good_grasps = 0  # grasps that got as far as the slip check

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, *, layout: Layout | None = None, seed: int | None = None
    ) -> HouseholdWorld:
        """A world seeded with ``seed`` (default: the scenario's seed)."""
        rng = np.random.default_rng(scenario.seed if seed is None else seed)
        return cls(layout or kitchen(), scenario, rng)

    # ------------------------------------------------------------------------------ the log

    def skill_calls(self, skill: str | None = None) -> list[LogEntry]:
        return [e for e in self.log if e.kind == "skill" and skill in (None, e.name)]

    def fired(self) -> list[LogEntry]:
        """The events and disturbances that have happened."""
        return [e for e in self.log if e.kind != "skill"]

    def successes(self, skill: str) -> int:
        return self._successes[skill]

    def _finish(self, skill: str, args: tuple[Any, ...], result: SkillResult) -> SkillResult:
        reason = result.data.get("reason")
        self._record(skill, args, result.ok, result.message, str(reason or ""))
        return result

    def _record(
        self, skill: str, args: tuple[Any, ...], ok: bool, message: str, reason: str = ""
    ) -> None:
        self.log.append(LogEntry("skill", skill, tuple(str(a) for a in args), ok, message, reason))
        if ok:
            self._successes[skill] += 1
            self._trigger(skill, self._successes[skill])

    def _trigger(self, skill: str, count: int) -> None:
        for d in self.scenario.noise.displace:
            if d.after is not None and (d.after.skill, d.after.count) == (skill, count):
                self._nudge(d)
        for e in self.scenario.events:
            if (e.after.skill, e.after.count) == (skill, count):
                self._apply(e)

    # ------------------------------------------------------------------------------- events

    def _apply(self, e: Event) -> None:
        problem = self._apply_event(e)
        args = (e.object, str(e.after))
        if problem is None:
            self.log.append(LogEntry("event", e.type, args, True, e.describe()))
        else:
            self.log.append(LogEntry("event", e.type, args, False, f"skipped: {problem}"))

    def _apply_event(self, e: Event) -> str | None:
        t = self.truth
        obj = e.object
        if e.type in ("set_property", "clear_property"):
            if not t.exists(obj):
                return f"{obj} is not in the world"
            props = t.properties.setdefault(obj, set())
            assert e.property is not None
            if e.type == "set_property":
                props.add(e.property)
            else:
                props.discard(e.property)
            return None
        if e.type == "move" and not t.exists(obj):
            return f"{obj} is not in the world"
        radius = t.radius(obj)
        if e.under is not None:
            cover = e.under
            if t.position(cover) is None:
                return f"{cover} is not standing anywhere"
            at = t.placements[cover]
            clash = [
                o
                for o in t.covers(cover)
                if o != obj
                and math.hypot(t.placements[o].x - at.x, t.placements[o].y - at.y)
                < radius + t.radius(o)
            ]
            if clash:
                return f"{', '.join(clash)} is already under {cover}"
            t.put(obj, Placement(at.region, at.x, at.y), under=cover)
            return None
        region = e.region
        assert region is not None
        if region in self.layout.regions:
            x, y = (
                (e.x, e.y)
                if e.x is not None and e.y is not None
                else self.layout.regions[region].center()
            )
        else:
            pos = t.position(region) if t.is_receptacle(region) else None
            if pos is None:
                return f"{region} is not standing anywhere"
            if region == obj:
                return f"{obj} cannot go into {region}"
            x, y = pos
        others = [o for o in t.objects_in(region) if o != obj]
        cap = t.capacity(region)
        if cap is not None and len(others) >= cap:
            return f"{region} is occupied by {', '.join(others)}"
        if region in self.layout.regions:
            hits = t.overlapping(region, x, y, radius, ignore=(obj,))
            if hits:
                return f"the spot on {region} is taken by {', '.join(hits)}"
        t.put(obj, Placement(region, x, y))
        return None

    def _nudge(self, d: Disturbance) -> None:
        t = self.truth
        obj = d.object
        assert obj is not None
        problem = None
        if t.position(obj) is None:
            problem = f"{obj} is not standing anywhere"
        elif obj in t.covered:
            problem = f"{obj} is under {t.covered[obj]}"
        else:
            p = t.placements[obj]
            x, y = p.x + d.dx, p.y + d.dy
            if not t.fits(p.region, x, y, t.radius(obj)):
                problem = f"{obj} would leave {p.region}"
            elif not t.free_at(p.region, x, y, t.radius(obj), ignore=(obj,)):
                hits = t.overlapping(p.region, x, y, t.radius(obj), (obj,))
                problem = f"{obj} would hit {', '.join(hits)}"
            else:
                t.put(obj, Placement(p.region, x, y))
        args = (obj, f"{d.dx:+.3f}", f"{d.dy:+.3f}")
        message = f"{obj} slid" if problem is None else f"skipped: {problem}"
        self.log.append(LogEntry("disturbance", "nudge", args, problem is None, message))

    # --------------------------------------------------------------------------- perception

    def look(self, target: str | None = None) -> Observation:
        """Point the camera at ``target`` (a region, a receptacle object or a piece of furniture)
        or, with None, along the base heading; report what is visible, with noise."""
        t = self.truth
        base = t.base
        if target is None:
            self.camera_heading = base.theta
            half = self.layout.view_fov / 2
            regions = [
                name
                for name, r in self.layout.regions.items()
                if abs(
                    _wrap(math.atan2(r.center()[1] - base.y, r.center()[0] - base.x) - base.theta)
                )
                <= half
            ]
        else:
            regions, (tx, ty) = self._aim(target)
            if tx != base.x or ty != base.y:
                self.camera_heading = math.atan2(ty - base.y, tx - base.x)
        viewed = [r for r in regions if self._viewable(r)]
        for r in viewed:  # receptacles seen in a viewed region: their contents are seen too
            for o in t.objects_in(r):
                if t.is_receptacle(o) and o not in viewed and self._viewable(o):
                    viewed.append(o)
        detections = []
        noise = self.scenario.noise
        for r in viewed:
            for obj in t.objects_in(r):
                if obj in t.covered:
                    continue
                if noise.miss_prob > 0 and self.rng.random() < noise.miss_prob:
                    continue
                p = t.placements[obj]
                dx, dy = (
                    self.rng.normal(0.0, noise.pose_sigma, 2) if noise.pose_sigma > 0 else (0, 0)
                )
                props = frozenset(t.properties.get(obj, set()) & VISIBLE)
                pose = Placement(r, float(p.x + dx), float(p.y + dy))
                seen_as = self._confused(obj)
                if seen_as is None:
                    detections.append(Detection(obj, r, pose, 1.0, props))
                else:  # a lookalike taken for the object it resembles
                    detections.append(Detection(seen_as, r, pose, CONFUSED, props))
        obs = Observation(tuple(viewed), tuple(detections))
        seen = ", ".join(f"{d.obj}@{d.region}" for d in detections) or "nothing"
        self._record(
            "look", (target,), True, f"viewed {', '.join(viewed) or 'nothing'}; saw {seen}"
        )
        return obs

    def _confused(self, obj: str) -> str | None:
        """The object the detector takes ``obj`` for (None: it sees ``obj``)."""
        for c in self.scenario.noise.confuse:
            if c.object == obj and (c.prob >= 1.0 or self.rng.random() < c.prob):
                return c.seen_as
        return None

    def _aim(self, target: str) -> tuple[list[str], tuple[float, float]]:
        """The regions a look at ``target`` covers, and the point the camera turns to."""
        t = self.truth
        if target in self.layout.regions:
            return [target], self.layout.regions[target].center()
        if target in self.layout.furniture:
            regions = [r.name for r in self.layout.regions_of(target)]
            return regions, self.layout.furniture[target].center()
        if target in t.specs:
            pos = t.position(target)
            if pos is not None and t.is_receptacle(target):
                return [target], pos
            return [], (t.base.x, t.base.y)
        known = sorted({*self.layout.regions, *self.layout.furniture, *t.specs})
        raise ValueError(f"cannot look at unknown {target!r}; targets: {', '.join(known)}")

    def _viewable(self, region: str) -> bool:
        """Within camera range of the true base and not inside a closed container."""
        t = self.truth
        if region in self.layout.regions:
            r = self.layout.regions[region]
            at: tuple[float, float] | None = r.center()
            if r.openable and not t.open.get(region, False):
                return False
        else:
            if not t.is_receptacle(region) or not t.visible(region):
                return False
            at = t.position(region)
            if at is None or not self._viewable(t.placements[region].region):
                return False
        assert at is not None
        return math.hypot(at[0] - t.base.x, at[1] - t.base.y) <= self.layout.view_range

    # -------------------------------------------------------------------------------- skills

    def base_conf(self) -> BaseConf:
        """The commanded (believed) base pose; the true one differs by odometry noise."""
        return self._commanded

    def holding(self) -> str | None:
        return self.truth.held

    def move_base(self, conf: Any) -> SkillResult:
        """Drive straight to ``conf`` (a BaseConf), or through a Motion's way points."""
        return self._finish("move_base", (conf,), self._move_base(conf))

    def _move_base(self, conf: Any) -> SkillResult:
        if isinstance(conf, Motion):
            if not conf.waypoints:
                return _fail("bad_value", "empty motion")
            path = list(conf.waypoints)
        elif isinstance(conf, BaseConf):
            path = [conf]
        else:
            return _fail("bad_value", f"not a base configuration: {conf!r}")
        goal = path[-1]
        hit = base_collision(self.layout, goal.x, goal.y)
        if hit is not None:
            return _fail("blocked", f"path blocked by {hit}: {goal} collides with it")
        start = self.truth.base
        points = [(start.x, start.y), *((q.x, q.y) for q in path)]
        radius = self.layout.robot_radius
        for (ax, ay), (bx, by) in itertools.pairwise(points):
            for f in self.layout.solid():
                clearance = min(radius, point_rect_distance(ax, ay, f.rect))
                if segment_rect_distance(ax, ay, bx, by, f.rect) < clearance - PATH_TOLERANCE:
                    return _fail("blocked", f"path blocked by {f.name}")
        sigma = self.scenario.noise.base_sigma
        if sigma > 0:
            dx, dy, dt = self.rng.normal(0.0, sigma, 3)
            true = BaseConf(goal.x + float(dx), goal.y + float(dy), _wrap(goal.theta + float(dt)))
        else:
            true = goal
        self.truth.base = true
        self._commanded = goal
        self.arm_target = None
        self.camera_heading = true.theta
        return SkillResult.success(f"at {goal}")

    def move_arm(self, target: Any) -> SkillResult:
        return self._finish("move_arm", (target,), self._move_arm(target))

    def _move_arm(self, target: Any) -> SkillResult:
        if not isinstance(target, ArmTarget):
            return _fail("bad_value", f"not an arm target: {target!r}")
        base = self.truth.base
        d = math.hypot(target.x - base.x, target.y - base.y)
        if d > self.layout.reach:
            return _fail(
                "out_of_reach",
                f"out of reach: ({target.x:.2f}, {target.y:.2f}) is {d:.2f} m from the base "
                f"(reach {self.layout.reach:.2f} m)",
            )
        self.arm_target = target
        return SkillResult.success(f"gripper at ({target.x:.2f}, {target.y:.2f}, {target.z:.2f})")

    def _gripper_near(self, x: float, y: float, radius: float) -> bool:
        a = self.arm_target
        return a is not None and math.hypot(a.x - x, a.y - y) <= GRASP_TOLERANCE + radius

    def grasp(self, obj: str, grasp: Any) -> SkillResult:
        return self._finish("grasp", (obj, grasp), self._grasp(obj, grasp))

    def _grasp(self, obj: str, grasp: Any) -> SkillResult:
        t = self.truth
        asked = obj
        if not isinstance(grasp, Grasp):
            return _fail("bad_value", f"not a grasp: {grasp!r}")
        if t.held is not None:
            return _fail("hand_full", f"the hand is not empty: it holds {t.held}")
        if self.arm_target is None or self.arm_target.phase != "at":
            return _fail("arm_not_ready", "the gripper is not at a grasp position")
        pos = t.position(obj) if obj in t.specs else None
        if pos is None or not self._gripper_near(*pos, t.radius(obj)):
            lookalike = self._lookalike_at(obj)
            if lookalike is None:
                return _fail("nothing_there", "nothing to grasp at the target")
            obj = lookalike  # the gripper closes on what is there
        if "broken" in t.properties.get(obj, set()):
            return _fail("broken", f"{obj} is broken: its pieces cannot be picked up")
        region = t.placements[obj].region
        why = t.inaccessible_reason(region)
        if why is not None:
            return _fail("closed" if why.endswith("closed") else "covered", why)
        if obj in t.covered:
            return _fail("covered", f"{obj} is covered by {t.covered[obj]}")
        self._good_grasps += 1
        scripted = any(
            d.kind == "slip" and d.attempt == self._good_grasps
            for d in self.scenario.noise.displace
        )
        slip_prob = self.scenario.noise.slip_prob
        if scripted or (slip_prob > 0 and self.rng.random() < slip_prob):
            self.log.append(
                LogEntry("disturbance", "slip", (obj,), True, f"grasp #{self._good_grasps} slips")
            )
            return _fail("slipped", "the object slipped")
        t.take(obj)
        return SkillResult.success(f"holding {asked}")  # the robot cannot tell a lookalike

    def _lookalike_at(self, obj: str) -> str | None:
        """A lookalike of ``obj`` under the gripper (a detector may have taken it for ``obj``)."""
        t = self.truth
        for other in t.objects:
            if t.spec(other).looks_like != obj and t.spec(obj).looks_like != other:
                continue
            pos = t.position(other)
            if pos is not None and self._gripper_near(*pos, t.radius(other)):
                return other
        return None

    def release(self, obj: str, pose: Any) -> SkillResult:
        return self._finish("release", (obj, pose), self._release(obj, pose))

    def _release(self, obj: str, place: Any) -> SkillResult:
        t = self.truth
        if t.held != obj:
            held = f"it holds {t.held}" if t.held else "the hand is empty"
            return _fail("not_held", f"not holding {obj}: {held}")
        if not isinstance(place, Placement):
            return _fail("bad_value", f"not a placement: {place!r}")
        radius = t.radius(obj)
        if (
            self.arm_target is None
            or self.arm_target.phase != "at"
            or not self._gripper_near(place.x, place.y, radius)
        ):
            return _fail("arm_not_ready", "the gripper is not at the placement")
        region = place.region
        if region == obj or not t.is_region(region):
            return _fail("not_region", f"cannot put {obj} into {region}: not a region")
        if region not in self.layout.regions and (
            t.spec(obj).cover or t.spec(obj).receptacle_capacity is not None
        ):
            return _fail("not_region", f"{obj} cannot go into {region}")
        why = t.inaccessible_reason(region)
        if why is not None:
            return _fail("closed" if why.endswith("closed") else "covered", why)
        if t.occupied(region):
            return _fail("occupied", f"{region} is occupied by {', '.join(t.objects_in(region))}")
        if "wet" in t.properties.get(obj, set()) and region.startswith("drawer"):
            return _fail("wet", f"{obj} is wet: it would soak {region}")
        if not t.fits(region, place.x, place.y, radius):
            return _fail("outside", f"{obj} does not fit at {place}: outside {region}")
        hits = t.overlapping(region, place.x, place.y, radius)
        under: tuple[str, ...] = ()
        if t.spec(obj).cover:  # a cover put down over objects within its rim covers them
            under = tuple(
                h
                for h in hits
                if not t.spec(h).cover
                and math.hypot(t.placements[h].x - place.x, t.placements[h].y - place.y)
                <= radius - t.radius(h)
            )
        blocked = [h for h in hits if h not in under]
        if blocked:
            return _fail("overlap", f"the placement on {region} is blocked by {', '.join(blocked)}")
        t.put(obj, place)
        for h in under:
            t.covered[h] = obj
        return SkillResult.success(f"{obj} released on {region}")

    def open(self, container: str) -> SkillResult:
        return self._finish("open", (container,), self._set_open(container, True))

    def close(self, container: str) -> SkillResult:
        return self._finish("close", (container,), self._set_open(container, False))

    def _set_open(self, container: str, value: bool) -> SkillResult:
        t = self.truth
        region = self.layout.regions.get(container)
        if region is None or not region.openable:
            return _fail("not_openable", f"{container} cannot be opened or closed")
        d = point_rect_distance(t.base.x, t.base.y, region.rect)
        if d > self.layout.reach:
            return _fail("out_of_reach", f"{container} is out of reach ({d:.2f} m away)")
        word = "open" if value else "closed"
        self.arm_target = None
        if t.open.get(container, False) == value:
            return SkillResult.success(f"{container} is already {word}")
        if value and container in t.jammed:
            return _fail("jammed", f"{container} is jammed: it does not open")
        blockers = t.blockers(container) if value else ()
        if blockers:
            return SkillResult.failure(
                f"{container} is blocked by {', '.join(blockers)} standing in front of it",
                reason="obstructed",
                blockers=blockers,
            )
        t.open[container] = value
        return SkillResult.success(f"{container} is {word}")

    def process(self, obj: str, appliance: str, how: str) -> SkillResult:
        return self._finish("process", (obj, appliance, how), self._process(obj, appliance, how))

    def _process(self, obj: str, appliance: str, how: str) -> SkillResult:
        t = self.truth
        region = self.layout.regions.get(appliance)
        if how == "dry" and region is not None and region.kind == "surface":
            pass  # anything can be wiped dry on a table
        elif region is None or region.process is None:
            return _fail("cannot_process", f"{appliance} cannot {how} anything")
        elif how != region.process:
            return _fail("cannot_process", f"{appliance} cannot {how} (it can {region.process})")
        place = t.placements.get(obj)
        if place is None or place.region != appliance or t.carried(obj):
            return _fail("not_in", f"{obj} is not in {appliance}")
        if region.openable and t.open.get(appliance, False):
            return _fail("open", f"{appliance} is open")
        props = t.properties.setdefault(obj, set())
        for blocking in (BLOCKING, HIDDEN_BLOCKING):
            for state, why in blocking.get(how, {}).items():
                if state in props:
                    return _fail(state, f"{obj} is {state}: {why}")
        others = [o for o in t.objects_in(appliance) if o != obj]
        if appliance in t.one_at_a_time and others:
            return _fail(
                "crowded",
                f"{', '.join(others)} {'is' if len(others) == 1 else 'are'} also in {appliance}: "
                f"{appliance} can {how} only {ONE_AT_A_TIME}",
            )
        props -= PROCESS_REMOVES.get(how, frozenset())
        if how in PROCESS_EFFECTS:
            props.add(PROCESS_EFFECTS[how])
            return SkillResult.success(f"{obj} is {PROCESS_EFFECTS[how]}")
        return SkillResult.success(f"{obj} is dry")
