"""The household scenario's places and belief: the fields that say where things are (regions,
receptacles, covers, positions and room), what is open, where the robot starts and what it
believes (:class:`PlaceFields`; the whole file is read by
:class:`~llmpas.worlds.household.scenario_parser.ScenarioParser`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from llmpas.fields import Fields, show
from llmpas.worlds.household.household_values import BaseConf, Placement
from llmpas.worlds.household.layout import Layout, ObjectSpec
from llmpas.worlds.household.scenario import (
    BeliefObject,
    InitialBelief,
    ScenarioError,
    name_list,
)
from llmpas.worlds.household.state import HIDDEN, STATES, TrueState, base_collision

_names = name_list
_fmt = show


class PlaceFields(Fields):
    """The scenario's shared TOML readers (:class:`~llmpas.fields.Fields`) and the household's
    own for objects and places: properties, catalogue objects, containers, locations, the open
    table, the robot's start and the initial belief."""

    def __init__(self, source: str, layout: Layout, catalogue: Mapping[str, ObjectSpec]) -> None:
        super().__init__(source, ScenarioError)
        self.layout = layout
        self.catalogue = catalogue

    def properties(self, value: Any, where: str) -> frozenset[str]:
        out = set()
        for i, p in enumerate(self.array(value, where)):
            name = self.string(p, f"{where}[{i}]")
            if name not in STATES:
                raise self.fail(
                    f"{where}[{i}]", f"unknown property {name!r}; properties: {_names(STATES)}"
                )
            out.add(name)
        return frozenset(out)

    def catalogue_object(self, value: Any, where: str) -> str:
        name = self.string(value, where)
        if name not in self.catalogue:
            raise self.fail(where, f"unknown object {name!r}; objects: {_names(self.catalogue)}")
        return name

    def house(self, value: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """The jammed doors and the appliances that process one object at a time."""
        t = self.table(value, "house", ("floor", "jammed", "one_at_a_time"))
        self.boolean(t.get("floor", False), "house.floor")  # read before parsing (the layout)
        jammed = self.containers(t.get("jammed", []), "house.jammed")
        where = "house.one_at_a_time"
        appliances = sorted(n for n, r in self.layout.regions.items() if r.process)
        alone: list[str] = []
        for i, raw in enumerate(self.array(t.get("one_at_a_time", []), where)):
            name = self.string(raw, f"{where}[{i}]")
            if name not in appliances:
                raise self.fail(
                    f"{where}[{i}]",
                    f"{name!r} is not an appliance; appliances: {_names(appliances)}",
                )
            if name not in alone:
                alone.append(name)
        return jammed, tuple(alone)

    def containers(self, value: Any, where: str) -> tuple[str, ...]:
        openable = sorted(n for n, r in self.layout.regions.items() if r.openable)
        out: list[str] = []
        for i, raw in enumerate(self.array(value, where)):
            name = self.string(raw, f"{where}[{i}]")
            if name not in openable:
                raise self.fail(
                    f"{where}[{i}]", f"{name!r} is not a door; containers: {_names(openable)}"
                )
            if name not in out:
                out.append(name)
        return tuple(out)

    def places(self, value: Any, where: str, covers: tuple[str, ...]) -> tuple[str, ...]:
        drawers = [n for n, r in self.layout.regions.items() if r.kind != "receptacle"]
        known = {*drawers, *covers}
        out: list[str] = []
        for i, raw in enumerate(self.array(value, where)):
            name = self.string(raw, f"{where}[{i}]")
            if name not in known:
                raise self.fail(f"{where}[{i}]", f"unknown place {name!r}; places: {_names(known)}")
            if name not in out:
                out.append(name)
        return tuple(out)

    def object_names(self, entries: list[tuple[str, Mapping[str, Any]]]) -> tuple[str, ...]:
        names: list[str] = []
        for where, t in entries:
            if "name" not in t:
                raise self.fail(f"{where}.name", "missing (required)")
            name = self.catalogue_object(t["name"], f"{where}.name")
            if name in names:
                raise self.fail(f"{where}.name", f"object {name!r} is listed twice")
            names.append(name)
        return tuple(names)

    def place_objects(
        self, entries: list[tuple[str, Mapping[str, Any]]], state: TrueState, belief: bool = False
    ) -> list[BeliefObject]:
        """Check object entries and put them into ``state``: plain objects first, then those
        under covers, then those inside receptacles. Returns them in entry order (a
        BeliefObject without placement for ``unknown = true``)."""
        by_name = {str(t["name"]): t for _, t in entries}
        receptacles = {n for n in by_name if self.catalogue[n].receptacle_capacity is not None}
        covers = {n for n in by_name if self.catalogue[n].cover}

        def stage(entry: tuple[str, Mapping[str, Any]]) -> int:
            t = entry[1]
            if t.get("inside") is not None or t.get("region") in receptacles:
                return 2
            return 1 if t.get("under") is not None else 0

        out: dict[str, BeliefObject] = {}
        for where, t in sorted(entries, key=stage):
            name = str(t["name"])
            spec = self.catalogue[name]
            props = (
                self.properties(t["properties"], f"{where}.properties")
                if "properties" in t
                else spec.properties
            )
            if belief:  # states the domain does not model are never believed
                props = props - HIDDEN
            if belief and self.boolean(t.get("unknown", False), f"{where}.unknown"):
                if any(k in t for k in _LOCATION_FIELDS):
                    raise self.fail(
                        f"{where}.unknown", "an object of unknown location takes no region/x/y"
                    )
                out[name] = BeliefObject(name, None, properties=props)
                continue
            region, under, inside = self.relation(where, t, spec, by_name, receptacles, covers)
            placement = self.locate(where, t, spec, region, under, inside, state, receptacles)
            self.check_room(where, spec, placement, under, inside, state)
            state.put(name, placement, under=under)
            state.properties[name] = set(props)
            out[name] = BeliefObject(name, placement, under, inside, props)
        return [out[str(t["name"])] for _, t in entries if str(t["name"]) in out]

    def relation(
        self,
        where: str,
        t: Mapping[str, Any],
        spec: ObjectSpec,
        by_name: Mapping[str, Any],
        receptacles: set[str],
        covers: set[str],
    ) -> tuple[str | None, str | None, str | None]:
        """The entry's region, cover and receptacle, checked against each other."""
        region = self.string(t["region"], f"{where}.region") if "region" in t else None
        under = self.string(t["under"], f"{where}.under") if "under" in t else None
        inside = self.string(t["inside"], f"{where}.inside") if "inside" in t else None
        if under is not None:
            if under not in covers:
                what = "is not a cover" if under in by_name else "is not in the scenario"
                raise self.fail(
                    f"{where}.under", f"unknown cover {under!r} ({what}); covers: {_names(covers)}"
                )
            if spec.cover:
                raise self.fail(f"{where}.under", f"{spec.name} is a cover: it cannot be under one")
        if inside is not None:
            if inside not in receptacles:
                what = "is not a receptacle" if inside in by_name else "is not in the scenario"
                raise self.fail(
                    f"{where}.inside",
                    f"unknown receptacle {inside!r} ({what}); receptacles: {_names(receptacles)}",
                )
            if region is not None and region != inside:
                raise self.fail(
                    f"{where}.region", f"{spec.name} is inside {inside}: its region is {inside!r}"
                )
        elif region in receptacles:
            inside = region
        if inside is not None:
            if under is not None:
                raise self.fail(
                    f"{where}.under", "an object cannot be both under a cover and in a receptacle"
                )
            if spec.cover or spec.receptacle_capacity is not None:
                what = "a cover" if spec.cover else "a receptacle"
                raise self.fail(
                    f"{where}.inside", f"{spec.name} is {what}: it cannot be inside another object"
                )
        return region, under, inside

    def locate(
        self,
        where: str,
        t: Mapping[str, Any],
        spec: ObjectSpec,
        region: str | None,
        under: str | None,
        inside: str | None,
        state: TrueState,
        receptacles: set[str],
    ) -> Placement:
        anchor_name = under if under is not None else inside
        if anchor_name is None:
            if region is None:
                raise self.fail(
                    f"{where}.region", "missing (give region, x, y; or under; or inside)"
                )
            if region not in self.layout.regions:
                known = {*self.layout.regions, *receptacles}
                raise self.fail(
                    f"{where}.region", f"unknown region {region!r}; regions: {_names(known)}"
                )
            for key in ("x", "y"):
                if key not in t:
                    raise self.fail(f"{where}.{key}", "missing (required with region)")
            x, y = self.number(t["x"], f"{where}.x"), self.number(t["y"], f"{where}.y")
            r = self.layout.regions[region]
            if not r.contains(x, y, margin=spec.radius - 1e-9):
                raise self.fail(
                    where,
                    f"{spec.name} at ({x:.3f}, {y:.3f}) is outside {region}: with its radius "
                    f"{spec.radius} m it must lie within {r.rect}",
                )
            return Placement(region, x, y)
        if anchor_name not in state.placements:
            raise self.fail(
                where,
                f"{spec.name} is {'under' if under is not None else 'inside'} {anchor_name}, "
                f"whose location is unknown: give {spec.name} a location or unknown = true",
            )
        anchor = state.placements[anchor_name]
        if under is not None:
            if region is not None and region != anchor.region:
                raise self.fail(
                    f"{where}.region",
                    f"{spec.name} is under {under}, which is on {anchor.region}, not {region}",
                )
            region = anchor.region
        else:
            region = anchor_name
        x = self.number(t.get("x", anchor.x), f"{where}.x")
        y = self.number(t.get("y", anchor.y), f"{where}.y")
        limit = state.radius(anchor_name) - spec.radius
        if limit < 0 or math.hypot(x - anchor.x, y - anchor.y) > limit + 1e-9:
            relation = "under" if under is not None else "inside"
            raise self.fail(
                where,
                f"{spec.name} at ({x:.3f}, {y:.3f}) does not fit {relation} {anchor_name} at "
                f"({anchor.x:.3f}, {anchor.y:.3f})",
            )
        return Placement(region, x, y)

    def check_room(
        self,
        where: str,
        spec: ObjectSpec,
        place: Placement,
        under: str | None,
        inside: str | None,
        state: TrueState,
    ) -> None:
        """Capacity and overlaps of a new object at ``place``."""
        region = place.region
        if state.occupied(region):
            raise self.fail(
                f"{where}.inside" if inside is not None else f"{where}.region",
                f"{region} is full: it holds {', '.join(state.objects_in(region))} "
                f"(capacity {state.capacity(region)})",
            )
        if under is None:
            hits = state.overlapping(region, place.x, place.y, spec.radius)
        else:  # under a cover: only the other objects under the same cover can be in the way
            hits = tuple(
                o
                for o in state.covers(under)
                if math.hypot(state.placements[o].x - place.x, state.placements[o].y - place.y)
                < spec.radius + state.radius(o) - 1e-9
            )
        if hits:
            raise self.fail(
                where,
                f"{spec.name} at ({place.x:.3f}, {place.y:.3f}) overlaps {', '.join(hits)} "
                f"on {region}",
            )

    def open_table(self, value: Any, where: str) -> dict[str, bool]:
        openable = sorted(n for n, r in self.layout.regions.items() if r.openable)
        out = dict.fromkeys(openable, False)
        if not isinstance(value, Mapping):
            raise self.fail(where, f"must be a table, got {_fmt(value)}")
        for key, v in value.items():
            if key not in self.layout.regions:
                raise self.fail(
                    f"{where}.{key}", f"unknown container {key!r}; containers: {_names(openable)}"
                )
            if key not in out:
                raise self.fail(
                    f"{where}.{key}", f"{key} cannot be opened; containers: {_names(openable)}"
                )
            out[key] = self.boolean(v, f"{where}.{key}")
        return out

    def robot(self, value: Any) -> BaseConf:
        t = self.table(value, "robot", ("x", "y", "theta"))
        hx, hy, ht = self.layout.home
        x = self.number(t.get("x", hx), "robot.x")
        y = self.number(t.get("y", hy), "robot.y")
        theta = self.number(t.get("theta", ht), "robot.theta")
        hit = base_collision(self.layout, x, y)
        if hit is not None:
            raise self.fail("robot", f"the base at ({x:.2f}, {y:.2f}) collides with {hit}")
        return BaseConf(x, y, theta)

    def belief(
        self,
        value: Any,
        entries: list[tuple[str, Mapping[str, Any]]],
        specs: Mapping[str, ObjectSpec],
        open_: Mapping[str, bool],
    ) -> InitialBelief:
        t = self.table(value, "belief", ("objects", "open", "searched", "jammed"))
        covers = tuple(n for n, s in specs.items() if s.cover)
        searched = self.places(t.get("searched", []), "belief.searched", covers)
        jammed = self.containers(t.get("jammed", []), "belief.jammed")
        overrides: dict[str, tuple[str, Mapping[str, Any]]] = {}
        truth_names = [str(e["name"]) for _, e in entries]
        for i, raw in enumerate(self.array(t.get("objects", []), "belief.objects")):
            where = f"belief.objects[{i}]"
            b = self.table(raw, where, (*_OBJECT_FIELDS, "unknown", "absent"))
            if "name" not in b:
                raise self.fail(f"{where}.name", "missing (required)")
            name = self.catalogue_object(b["name"], f"{where}.name")
            if name not in truth_names:
                raise self.fail(
                    f"{where}.name",
                    f"{name!r} is not among the scenario's objects: {_names(truth_names)}",
                )
            if name in overrides:
                raise self.fail(f"{where}.name", f"object {name!r} is listed twice")
            told = self.properties(b.get("properties", []), f"{where}.properties")
            hidden = sorted(HIDDEN & told)
            if hidden:
                raise self.fail(
                    f"{where}.properties",
                    f"{', '.join(hidden)}: a state the domain does not model is never believed",
                )
            overrides[name] = (where, b)
        merged: list[tuple[str, Mapping[str, Any]]] = []
        for where, e in entries:
            name = str(e["name"])
            if name not in overrides:
                merged.append((where, e))
                continue
            b_where, b = overrides[name]
            if self.boolean(b.get("absent", False), f"{b_where}.absent"):
                if len(b) > 2:
                    raise self.fail(f"{b_where}.absent", "an absent object takes no other field")
                continue
            moved = b.get("unknown") or any(k in b for k in _LOCATION_FIELDS)
            keep = {k: v for k, v in e.items() if k not in _LOCATION_FIELDS or not moved}
            merged.append((b_where, {**keep, **{k: v for k, v in b.items() if k != "absent"}}))
        state = TrueState(self.layout, specs, BaseConf(*self.layout.home))
        objects = self.place_objects(merged, state, belief=True)
        believed_open = dict(open_)
        overridden = self.open_table(t.get("open", {}), "belief.open")
        believed_open.update({k: overridden[k] for k in t.get("open", {})})
        return InitialBelief(tuple(objects), believed_open, searched, jammed)

    def scenario_object(self, value: Any, where: str, names: tuple[str, ...]) -> str:
        name = self.catalogue_object(value, where)
        if name not in names:
            raise self.fail(where, f"{name!r} is not among the scenario's objects: {_names(names)}")
        return name


_LOCATION_FIELDS = ("region", "x", "y", "under", "inside")
_OBJECT_FIELDS = ("name", *_LOCATION_FIELDS, "properties")
