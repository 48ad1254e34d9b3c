"""Small builders for household world tests."""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from llmpas.worlds.household.household_values import ArmTarget, BaseConf, Grasp
from llmpas.worlds.household.layout import kitchen
from llmpas.worlds.household.scenario import Scenario
from llmpas.worlds.household.sim import HouseholdWorld

UP = math.pi / 2
DOWN = -math.pi / 2
TOP = Grasp("top")

# base poses (clear of the furniture, within reach of the named places)
AT_TABLE1 = BaseConf(1.5, 3.8, UP)
AT_TABLE2 = BaseConf(4.5, 3.8, UP)
AT_SINK = BaseConf(1.15, 0.95, DOWN)
AT_STOVE = BaseConf(2.35, 0.95, DOWN)
AT_MICROWAVE = BaseConf(3.75, 0.95, DOWN)
AT_FRIDGE = BaseConf(4.85, 2.1, 0.0)
AT_CABINET = BaseConf(0.85, 2.35, math.pi)

BASE: dict[str, Any] = {
    "name": "test",
    "objects": [
        {"name": "cube", "region": "table1_right", "x": 1.8, "y": 4.45},
        {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
    ],
    "task": {"goal": "(and (On cube bowl))"},
}


def data(**changes: Any) -> dict[str, Any]:
    """The base scenario as a dict, with top-level keys replaced."""
    d = copy.deepcopy(BASE)
    d.update(copy.deepcopy(changes))
    return d


def scenario(**changes: Any) -> Scenario:
    return Scenario.from_dict(data(**changes), source="test.toml")


def world(seed: int = 0, **changes: Any) -> HouseholdWorld:
    return HouseholdWorld(kitchen(), scenario(**changes), np.random.default_rng(seed))


def at(x: float, y: float, z: float = 0.8, phase: str = "at") -> ArmTarget:
    return ArmTarget(x, y, z, TOP, phase)


def true_xy(w: HouseholdWorld, obj: str) -> tuple[float, float]:
    pos = w.truth.position(obj)
    assert pos is not None, f"{obj} has no position"
    return pos


def pick(w: HouseholdWorld, obj: str) -> None:
    """Grasp ``obj`` at its true position (the base must already be near it)."""
    x, y = true_xy(w, obj)
    assert w.move_arm(at(x, y)).ok
    r = w.grasp(obj, TOP)
    assert r.ok, r.message
