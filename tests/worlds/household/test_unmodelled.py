"""Causes the planning domain does not model: object states (frozen, greasy, waxed) and the house
rule that an appliance processes one object at a time. The simulator fails the process with the
cause named in the message; no camera reports the cause and the robot never believes it."""

from __future__ import annotations

from typing import Any

import pytest

from llmpas.worlds.household.household_plugin import belief_from, household_for
from llmpas.worlds.household.scenario import Scenario, ScenarioError
from llmpas.worlds.household.sim import HouseholdWorld
from llmpas.worlds.household.state import HIDDEN, PROPERTIES, STATES
from tests.worlds.household import support
from tests.worlds.household.support import AT_SINK, AT_STOVE

TASK = {"goal": "(and (Holding apple))"}


def scenario(**changes: Any) -> Scenario:
    return support.scenario(**{"task": TASK, **changes})


def world(**changes: Any) -> HouseholdWorld:
    return support.world(**{"task": TASK, **changes})


def _in(obj: str, region: str, x: float, y: float, *props: str) -> dict[str, Any]:
    entry: dict[str, Any] = {"name": obj, "region": region, "x": x, "y": y}
    if props:
        entry["properties"] = list(props)
    return entry


def test_hidden_states_are_states_of_the_world_but_not_of_the_domain() -> None:
    assert HIDDEN and not HIDDEN & PROPERTIES and STATES == PROPERTIES | HIDDEN


@pytest.mark.parametrize(
    ("state", "appliance", "how", "why"),
    [
        ("frozen", "stove", "cook", "apple is frozen: frozen food cannot be cooked"),
        ("waxed", "stove", "cook", "apple is waxed: waxed fruit is not cooked"),
        ("greasy", "fridge", "cool", "apple is greasy: greasy things do not go into the fridge"),
    ],
)
def test_a_hidden_state_fails_the_process_with_the_state_named(
    state: str, appliance: str, how: str, why: str
) -> None:
    xy = {"stove": (2.35, 0.3), "fridge": (5.5, 2.1)}[appliance]
    w = world(objects=[_in("apple", appliance, *xy, state)])
    r = w.process("apple", appliance, how)
    assert not r.ok and r.data["reason"] == state and r.message == why
    assert w.log[-1].reason == state and not w.log[-1].ok
    assert state in w.truth.properties["apple"]  # the failure does not change the apple


@pytest.mark.parametrize("state", sorted(HIDDEN))
def test_rinsing_removes_every_hidden_state(state: str) -> None:
    w = world(objects=[_in("apple", "sink", 1.15, 0.3, state)])
    assert w.process("apple", "sink", "clean").ok
    assert w.truth.properties["apple"] == {"cleaned"}


def test_heating_thaws_and_then_the_apple_cooks() -> None:
    w = world(objects=[_in("apple", "microwave", 3.75, 0.3, "frozen")])
    assert w.process("apple", "microwave", "heat").ok
    assert w.truth.properties["apple"] == {"heated"}
    w2 = world(objects=[_in("apple", "stove", 2.35, 0.3)])  # not frozen: it cooks
    assert w2.process("apple", "stove", "cook").ok


def test_no_camera_reports_a_hidden_state() -> None:
    w = world(objects=[_in("apple", "stove", 2.35, 0.3, "frozen", "dirty")])
    w.move_base(AT_STOVE)
    d = w.look("stove").find("apple")
    assert d is not None and d.properties == frozenset({"dirty"})


def test_the_robot_never_believes_a_hidden_state() -> None:
    s = scenario(objects=[_in("apple", "table1_left", 1.2, 4.45, "frozen", "dirty")])
    assert s.object("apple").properties == {"frozen", "dirty"}  # the truth has both
    assert s.belief.get("apple").properties == {"dirty"}  # type: ignore[union-attr]
    belief = belief_from(household_for(s), s)
    assert {a.predicate for a in belief.facts if a.args == ("apple",)} >= {"dirty"}
    assert not {a for a in belief.facts if a.predicate in HIDDEN}
    with pytest.raises(ScenarioError, match=r"belief.objects\[0\].properties: frozen: a state"):
        scenario(
            objects=[_in("apple", "table1_left", 1.2, 4.45)],
            belief={"objects": [{"name": "apple", "properties": ["frozen"]}]},
        )


def test_an_unknown_state_names_every_known_one() -> None:
    with pytest.raises(ScenarioError, match=r"unknown property 'icy'; properties: .*frozen.*waxed"):
        scenario(objects=[_in("apple", "table1_left", 1.2, 4.45, "icy")])
    s = support.scenario(
        events=[
            {
                "after": {"skill": "grasp", "count": 1},
                "type": "set_property",
                "object": "cube",
                "property": "greasy",
            }
        ]
    )
    assert s.events[0].property == "greasy"


def test_one_at_a_time_fails_the_process_while_another_object_is_in_the_appliance() -> None:
    objects = [_in("apple", "sink", 1.0, 0.3), _in("mug", "sink", 1.35, 0.3)]
    w = world(objects=objects, house={"one_at_a_time": ["sink"]})
    r = w.process("apple", "sink", "clean")
    assert not r.ok and r.data["reason"] == "crowded"
    assert r.message == "mug is also in sink: sink can clean only one thing at a time"
    w.move_base(AT_SINK)
    w.truth.take("mug")  # the mug out: the apple is rinsed
    assert w.process("apple", "sink", "clean").ok
    # without the rule, the sink rinses with the mug beside (as before)
    assert world(objects=objects).process("apple", "sink", "clean").ok


def test_one_at_a_time_names_appliances_only() -> None:
    s = support.scenario(house={"one_at_a_time": ["stove", "stove"]})
    assert s.one_at_a_time == ("stove",)
    with pytest.raises(ScenarioError, match=r"house.one_at_a_time\[0\]: 'table1_left' is not an"):
        support.scenario(house={"one_at_a_time": ["table1_left"]})
