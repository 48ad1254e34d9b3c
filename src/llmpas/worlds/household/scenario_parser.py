"""Reading a household scenario file (:class:`ScenarioParser`): the whole file, its noise,
disturbances, events and goal, on the places and belief of
:class:`~llmpas.worlds.household.scenario_places.PlaceFields`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from llmpas.fields import show
from llmpas.language.language_errors import PddlSyntaxError
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.worlds.household.household_values import BaseConf
from llmpas.worlds.household.scenario import (
    DISTURBANCE_KINDS,
    EVENT_TYPES,
    GOAL_PREDICATES,
    MAX_NUDGE,
    SKILLS,
    Confusion,
    Disturbance,
    Event,
    Noise,
    ObjectInit,
    Scenario,
    Trigger,
    name_list,
)
from llmpas.worlds.household.scenario_places import _OBJECT_FIELDS, PlaceFields
from llmpas.worlds.household.state import STATES, TrueState

_names = name_list
_fmt = show


class ScenarioParser(PlaceFields):
    """A scenario file's fields, section by section (see :mod:`~llmpas.worlds.household.scenario`
    for the format)."""

    def scenario(self, data: Mapping[str, Any]) -> Scenario:
        top = self.table(
            data,
            "",
            (
                "name",
                "description",
                "seed",
                "noise",
                "objects",
                "open",
                "robot",
                "belief",
                "task",
                "events",
                "house",
            ),
        )
        for key in ("name", "objects", "task"):
            if key not in top:
                raise self.fail(key, "missing (required)")
        name = self.string(top["name"], "name")
        description = top.get("description", "")
        if not isinstance(description, str):
            raise self.fail("description", f"must be a string, got {_fmt(description)}")
        seed = self.integer(top.get("seed", 0), "seed")

        raw_objects = self.array(top["objects"], "objects")
        if not raw_objects:
            raise self.fail("objects", "must list at least one object")
        entries = [
            (f"objects[{i}]", self.table(o, f"objects[{i}]", _OBJECT_FIELDS))
            for i, o in enumerate(raw_objects)
        ]
        names = self.object_names(entries)
        event_objects = self.event_objects(top.get("events", []))
        specs = {n: self.catalogue[n] for n in (*names, *event_objects)}

        truth = TrueState(self.layout, specs, BaseConf(*self.layout.home))
        resolved = self.place_objects(entries, truth)
        objects = tuple(
            ObjectInit(r.name, r.placement, r.under, r.inside, r.properties)
            for r in resolved
            if r.placement is not None
        )
        jammed, one_at_a_time = self.house(top.get("house", {}))
        open_ = self.open_table(top.get("open", {}), "open")
        for r in jammed:
            if open_[r]:
                raise self.fail("house.jammed", f"{r} is jammed: it cannot be open")
        robot = self.robot(top.get("robot", {}))
        belief = self.belief(top.get("belief", {}), entries, specs, open_)
        noise = self.noise(top.get("noise", {}), names)
        events = self.events(top.get("events", []), names, truth)
        goal = self.goal(top["task"], (*names, *event_objects))
        return Scenario(
            name=name,
            description=description,
            seed=seed,
            noise=noise,
            objects=objects,
            open=open_,
            robot=robot,
            belief=belief,
            goal=goal,
            events=events,
            specs=specs,
            source=self.source,
            layout=self.layout,
            jammed=jammed,
            one_at_a_time=one_at_a_time,
        )

    def event_objects(self, raw: Any) -> tuple[str, ...]:
        """Objects that only enter the world through ``occupy`` events (checked later)."""
        out: list[str] = []
        if isinstance(raw, list):
            for e in raw:
                if isinstance(e, Mapping) and e.get("type") == "occupy":
                    obj = e.get("object")
                    if isinstance(obj, str) and obj in self.catalogue and obj not in out:
                        out.append(obj)
        return tuple(out)

    def noise(self, value: Any, names: tuple[str, ...]) -> Noise:
        fields = ("pose_sigma", "base_sigma", "miss_prob", "slip_prob", "displace", "confuse")
        t = self.table(value, "noise", fields)
        confuse = tuple(
            self.confusion(c, f"noise.confuse[{i}]", names)
            for i, c in enumerate(self.array(t.get("confuse", []), "noise.confuse"))
        )
        displace = tuple(
            self.disturbance(d, f"noise.displace[{i}]", names)
            for i, d in enumerate(self.array(t.get("displace", []), "noise.displace"))
        )
        return Noise(
            pose_sigma=self.sigma(t.get("pose_sigma", 0.0), "noise.pose_sigma"),
            base_sigma=self.sigma(t.get("base_sigma", 0.0), "noise.base_sigma"),
            miss_prob=self.probability(t.get("miss_prob", 0.0), "noise.miss_prob"),
            slip_prob=self.probability(t.get("slip_prob", 0.0), "noise.slip_prob"),
            displace=displace,
            confuse=confuse,
        )

    def confusion(self, value: Any, where: str, names: tuple[str, ...]) -> Confusion:
        t = self.table(value, where, ("object", "as", "prob"))
        for key in ("object", "as"):
            if key not in t:
                raise self.fail(f"{where}.{key}", "missing (required)")
        obj = self.scenario_object(t["object"], f"{where}.object", names)
        seen_as = self.catalogue_object(t["as"], f"{where}.as")
        if seen_as == obj:
            raise self.fail(f"{where}.as", f"{obj} cannot be taken for itself")
        prob = self.probability(t.get("prob", 1.0), f"{where}.prob")
        return Confusion(obj, seen_as, prob)

    def disturbance(self, value: Any, where: str, names: tuple[str, ...]) -> Disturbance:
        if not isinstance(value, Mapping):
            raise self.fail(where, f"must be a table, got {_fmt(value)}")
        kind = self.string(value.get("kind"), f"{where}.kind")
        if kind == "slip":
            t = self.table(value, where, ("kind", "attempt"))
            return Disturbance(
                "slip", attempt=self.integer(t.get("attempt", 1), f"{where}.attempt", 1)
            )
        if kind == "nudge":
            t = self.table(value, where, ("kind", "object", "dx", "dy", "after"))
            for key in ("object", "after"):
                if key not in t:
                    raise self.fail(f"{where}.{key}", "missing (required)")
            obj = self.scenario_object(t["object"], f"{where}.object", names)
            if self.catalogue[obj].cover:
                raise self.fail(f"{where}.object", f"{obj} is a cover: it cannot be nudged")
            dx = self.number(t.get("dx", 0.0), f"{where}.dx")
            dy = self.number(t.get("dy", 0.0), f"{where}.dy")
            if math.hypot(dx, dy) > MAX_NUDGE:
                raise self.fail(
                    where, f"a nudge moves at most {MAX_NUDGE} m (use an event to move objects)"
                )
            after = self.trigger(t["after"], f"{where}.after")
            return Disturbance("nudge", object=obj, dx=dx, dy=dy, after=after)
        raise self.fail(
            f"{where}.kind", f"unknown disturbance {kind!r}; kinds: {', '.join(DISTURBANCE_KINDS)}"
        )

    def trigger(self, value: Any, where: str) -> Trigger:
        t = self.table(value, where, ("skill", "count"))
        for key in ("skill", "count"):
            if key not in t:
                raise self.fail(f"{where}.{key}", "missing (required)")
        skill = self.string(t["skill"], f"{where}.skill")
        if skill not in SKILLS:
            raise self.fail(
                f"{where}.skill", f"unknown skill {skill!r}; skills: {', '.join(SKILLS)}"
            )
        return Trigger(skill, self.integer(t["count"], f"{where}.count", 1))

    def events(self, value: Any, names: tuple[str, ...], truth: TrueState) -> tuple[Event, ...]:
        out = []
        present = list(names)
        receptacles = {n for n in truth.specs if truth.specs[n].receptacle_capacity is not None}
        covers = sorted(n for n in names if self.catalogue[n].cover)
        for i, raw in enumerate(self.array(value, "events")):
            where = f"events[{i}]"
            if not isinstance(raw, Mapping):
                raise self.fail(where, f"must be a table, got {_fmt(raw)}")
            if "type" not in raw:
                raise self.fail(f"{where}.type", "missing (required)")
            kind = self.string(raw["type"], f"{where}.type")
            if kind not in EVENT_TYPES:
                raise self.fail(
                    f"{where}.type", f"unknown event type {kind!r}; types: {', '.join(EVENT_TYPES)}"
                )
            if kind in ("move", "occupy"):
                allowed: tuple[str, ...] = (
                    "type",
                    "after",
                    "object",
                    "region",
                    "into",
                    "x",
                    "y",
                    "under",
                )
            else:
                allowed = ("type", "after", "object", "property")
            t = self.table(raw, where, allowed)
            for key in ("after", "object"):
                if key not in t:
                    raise self.fail(f"{where}.{key}", "missing (required)")
            after = self.trigger(t["after"], f"{where}.after")
            if kind == "occupy":
                obj = self.catalogue_object(t["object"], f"{where}.object")
            else:
                obj = self.scenario_object(t["object"], f"{where}.object", tuple(present))
            if obj not in present:
                present.append(obj)
            if kind in ("set_property", "clear_property"):
                if "property" not in t:
                    raise self.fail(f"{where}.property", "missing (required)")
                prop = self.string(t["property"], f"{where}.property")
                if prop not in STATES:
                    raise self.fail(
                        f"{where}.property",
                        f"unknown property {prop!r}; properties: {_names(STATES)}",
                    )
                out.append(Event(after, kind, obj, property=prop))
                continue
            targets = [k for k in ("region", "into", "under") if k in t]
            if len(targets) != 1:
                raise self.fail(where, f"a {kind} event needs exactly one of region, into, under")
            key = targets[0]
            target = self.string(t[key], f"{where}.{key}")
            spec = self.catalogue[obj]
            if key == "under":
                if "x" in t or "y" in t:
                    raise self.fail(f"{where}.under", "an object moved under a cover takes no x, y")
                if target not in covers:
                    raise self.fail(
                        f"{where}.under", f"unknown cover {target!r}; covers: {_names(covers)}"
                    )
                if spec.cover:
                    raise self.fail(f"{where}.object", f"{obj} is a cover: it cannot be under one")
                if self.catalogue[target].radius < spec.radius:
                    raise self.fail(f"{where}.under", f"{obj} does not fit under {target}")
                out.append(Event(after, kind, obj, under=target))
                continue
            if target in receptacles and target in present:
                if "x" in t or "y" in t:
                    raise self.fail(
                        f"{where}.{key}", "an object put into a receptacle takes no x, y"
                    )
                if target == obj or spec.cover or spec.receptacle_capacity is not None:
                    raise self.fail(f"{where}.object", f"{obj} cannot go into {target}")
                if self.catalogue[target].radius < spec.radius:
                    raise self.fail(f"{where}.{key}", f"{obj} does not fit into {target}")
                out.append(Event(after, kind, obj, region=target))
                continue
            if target not in self.layout.regions:
                known = sorted({*self.layout.regions, *(r for r in receptacles if r in present)})
                raise self.fail(
                    f"{where}.{key}", f"unknown region {target!r}; regions: {', '.join(known)}"
                )
            x = self.number(t["x"], f"{where}.x") if "x" in t else None
            y = self.number(t["y"], f"{where}.y") if "y" in t else None
            if (x is None) != (y is None):
                raise self.fail(where, "give both x and y, or neither (the region's centre)")
            r = self.layout.regions[target]
            cx, cy = (x, y) if x is not None and y is not None else r.center()
            if not r.contains(cx, cy, margin=spec.radius - 1e-9):
                raise self.fail(
                    where,
                    f"{obj} at ({cx:.3f}, {cy:.3f}) is outside {target}: with its radius "
                    f"{spec.radius} m it must lie within {r.rect}",
                )
            out.append(Event(after, kind, obj, region=target, x=x, y=y))
        return tuple(out)

    def goal(self, value: Any, names: tuple[str, ...]) -> str:
        t = self.table(value, "task", ("goal",))
        if "goal" not in t:
            raise self.fail("task.goal", "missing (required)")
        goal = t["goal"]
        if not isinstance(goal, str):
            raise self.fail("task.goal", f"must be PDDL text (a string), got {_fmt(goal)}")
        try:
            exprs = parse_all(goal, "task.goal")
        except PddlSyntaxError as e:
            raise self.fail("task.goal", f"malformed PDDL: {e.message}") from None
        if len(exprs) != 1 or not isinstance(exprs[0], SList):
            raise self.fail("task.goal", "must be one parenthesised PDDL formula")
        known = {*names, *self.layout.regions, *self.layout.furniture}
        self.check_atoms(exprs[0], known)
        return goal.strip()

    def check_atoms(self, e: SList, known: set[str]) -> None:
        head = e.head()
        if head is not None and head in GOAL_PREDICATES:
            args = e.items[1:]
            if len(args) != GOAL_PREDICATES[head]:
                raise self.fail(
                    "task.goal", f"({head} ...) takes {GOAL_PREDICATES[head]} argument(s)"
                )
            for a in args:
                if not isinstance(a, Sym):
                    raise self.fail("task.goal", f"({head} ...) takes names, not formulas")
                if not a.text.startswith("?") and a.text not in known:
                    raise self.fail(
                        "task.goal",
                        f"unknown name {a.text!r} in ({head} ...); "
                        f"names: {', '.join(sorted(known))}",
                    )
            return
        for item in e.items:
            if isinstance(item, SList):
                self.check_atoms(item, known)
