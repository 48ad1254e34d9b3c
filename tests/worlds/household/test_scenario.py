"""Scenario files: the shipped ones load; bad ones fail with one line naming file and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.worlds.household.household_values import Placement
from llmpas.worlds.household.layout import kitchen
from llmpas.worlds.household.scenario import (
    SCENARIO_DIR,
    Scenario,
    ScenarioError,
    builtin_scenario,
    builtin_scenarios,
    load_scenario,
)

from .support import data, scenario

EXPECTED = {
    "nominal",
    "object-loss-table",
    "object-loss-drawer",
    "object-loss-basket",
    "action-blocking-microwave",
    "action-blocking-bowl",
    "state-change-apple",
}


def test_every_shipped_scenario_loads() -> None:
    assert set(builtin_scenarios()) >= EXPECTED
    for path in sorted(SCENARIO_DIR.glob("*.toml")):
        s = load_scenario(path)
        assert s.name == path.stem
        assert s.goal.startswith("(")
        assert s.description
        state = s.initial_state(kitchen())
        assert set(state.objects) == set(s.object_names)


def test_shipped_scenarios_say_what_they_promise() -> None:
    nominal = builtin_scenario("nominal")
    assert nominal.events == ()
    assert nominal.goal == "(and (On cube bowl))"
    assert nominal.object("cube").placement.region == "table1_right"

    table = builtin_scenario("object-loss-table")
    (e,) = table.events
    assert (e.after.skill, e.after.count, e.type, e.object) == ("move_base", 1, "move", "cube")
    assert e.region == "table2_right"

    drawer = builtin_scenario("object-loss-drawer")
    assert drawer.events[0].region == "drawer2" and drawer.open["drawer2"] is False

    basket = builtin_scenario("object-loss-basket")
    assert basket.events[0].under == "basket"

    micro = builtin_scenario("action-blocking-microwave")
    assert micro.object("mug").placement.region == "microwave"
    assert micro.belief.get("mug") is None  # the robot believes the microwave is empty
    assert micro.goal == "(and (Heated bread))"

    bowl = builtin_scenario("action-blocking-bowl")
    assert bowl.object("black_cube").inside == "bowl"
    assert bowl.belief.get("black_cube") is None

    apple = builtin_scenario("state-change-apple")
    (e,) = apple.events
    assert (e.after.skill, e.after.count, e.type, e.property) == (
        "grasp",
        1,
        "set_property",
        "dirty",
    )
    assert apple.goal == "(and (Cooled apple))"


def test_defaults_belief_is_the_truth() -> None:
    s = scenario()
    assert s.belief.places() == {o.name: o.placement for o in s.objects}
    assert dict(s.belief.open) == dict(s.open)
    assert all(not v for v in s.open.values())
    assert s.noise.miss_prob == 0.0 and s.seed == 0
    assert (s.robot.x, s.robot.y) == kitchen().home[:2]


def test_belief_overrides() -> None:
    s = Scenario.from_dict(
        data(
            objects=[
                {"name": "basket", "region": "table2_right", "x": 4.8, "y": 4.5},
                {"name": "cube", "under": "basket"},
                {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
                {"name": "apple", "region": "table1_left", "x": 1.2, "y": 4.45},
                {"name": "mug", "region": "microwave", "x": 3.75, "y": 0.3},
            ],
            open={"microwave": True},
            belief={
                "objects": [
                    {"name": "cube", "region": "table1_right", "x": 1.8, "y": 4.45},
                    {"name": "apple", "unknown": True},
                    {"name": "mug", "absent": True},
                    {"name": "bowl", "properties": ["dirty"]},
                ],
                "open": {"microwave": False},
            },
        )
    )
    cube = s.object("cube")
    assert cube.under == "basket" and cube.placement == Placement("table2_right", 4.8, 4.5)
    assert s.belief.get("cube") is not None
    assert s.belief.places()["cube"] == Placement("table1_right", 1.8, 4.45)
    assert s.belief.places()["apple"] is None
    assert "mug" not in s.belief.places()
    bowl = s.belief.get("bowl")
    assert bowl is not None and bowl.properties == {"dirty"}
    assert bowl.placement == s.object("bowl").placement
    assert s.open["microwave"] is True and s.belief.open["microwave"] is False
    assert s.belief.open_regions() == ()


def test_contents_default_to_their_receptacle_and_cover() -> None:
    s = scenario(
        objects=[
            {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
            {"name": "cube", "region": "bowl"},
            {"name": "basket", "region": "table1_left", "x": 1.2, "y": 4.5},
            {"name": "apple", "under": "basket", "properties": ["dirty"]},
        ]
    )
    assert s.object("cube").placement == Placement("bowl", 4.2, 4.45)
    assert s.object("cube").inside == "bowl"
    assert s.object("apple").placement == Placement("table1_left", 1.2, 4.5)
    assert s.object("apple").properties == {"dirty"}
    state = s.initial_state()
    assert state.inside == {"cube": "bowl"} and state.covered == {"apple": "basket"}


# ------------------------------------------------------------------------------- bad files

GOOD = """\
name = "bad"
seed = 1

[noise]
pose_sigma = 0.01
miss_prob = 0.1

[[objects]]
name = "cube"
region = "table1_right"
x = 1.8
y = 4.45

[[objects]]
name = "bowl"
region = "table2_left"
x = 4.2
y = 4.45

[task]
goal = "(and (On cube bowl))"
"""

EVENT = """
[[events]]
after = { skill = "move_base", count = 1 }
type = "move"
object = "cube"
region = "table2_right"
"""

# (name, text change: (old, new) or text to append, field, message fragment)
BAD: list[tuple[str, tuple[str, str] | str, str, str]] = [
    (
        "unknown region",
        ('region = "table1_right"', 'region = "tabel1"'),
        "objects[0].region",
        "unknown region 'tabel1'; regions:",
    ),
    (
        "unknown object",
        ('name = "cube"', 'name = "cbe"'),
        "objects[0].name",
        "unknown object 'cbe'",
    ),
    (
        "unknown cover",
        ('region = "table1_right"\nx = 1.8\ny = 4.45', 'under = "bowl"'),
        "objects[0].under",
        "unknown cover 'bowl'",
    ),
    (
        "unknown receptacle",
        (
            'region = "table2_left"\nx = 4.2\ny = 4.45',
            'region = "table2_left"\nx = 4.2\ny = 4.6\ninside = "cube"',
        ),
        "objects[1].inside",
        "unknown receptacle 'cube'",
    ),
    ("outside region", ("x = 1.8", "x = 1.2"), "objects[0]", "outside table1_right"),
    (
        "outside region edge",
        ('y = 4.45\n\n[[objects]]\nname = "bowl"', 'y = 4.99\n\n[[objects]]\nname = "bowl"'),
        "objects[0]",
        "outside table1_right",
    ),
    (
        "overlap",
        ('region = "table2_left"\nx = 4.2', 'region = "table1_right"\nx = 1.85'),
        "objects[1]",
        "overlaps cube",
    ),
    (
        "probability",
        ("miss_prob = 0.1", "miss_prob = 1.5"),
        "noise.miss_prob",
        "probability in [0, 1]",
    ),
    ("negative sigma", ("pose_sigma = 0.01", "pose_sigma = -0.01"), "noise.pose_sigma", ">= 0"),
    (
        "slip probability",
        ("miss_prob = 0.1", 'slip_prob = "often"'),
        "noise.slip_prob",
        "finite number",
    ),
    (
        "event type",
        EVENT.replace('"move"', '"teleport"'),
        "events[0].type",
        "unknown event type 'teleport'",
    ),
    (
        "event skill",
        EVENT.replace('"move_base"', '"drive"'),
        "events[0].after.skill",
        "unknown skill 'drive'",
    ),
    ("event count", EVENT.replace("count = 1", "count = 0"), "events[0].after.count", "at least 1"),
    (
        "event region",
        EVENT.replace('"table2_right"', '"table3"'),
        "events[0].region",
        "unknown region 'table3'",
    ),
    (
        "event object",
        EVENT.replace('object = "cube"', 'object = "mug"'),
        "events[0].object",
        "not among the scenario's objects",
    ),
    (
        "event property",
        EVENT.replace('type = "move"', 'type = "set_property"').replace(
            'region = "table2_right"', 'property = "sticky"'
        ),
        "events[0].property",
        "unknown property 'sticky'",
    ),
    (
        "goal not text",
        ('goal = "(and (On cube bowl))"', "goal = 3"),
        "task.goal",
        "must be PDDL text",
    ),
    (
        "goal unknown name",
        ('goal = "(and (On cube bowl))"', 'goal = "(and (On cube bwol))"'),
        "task.goal",
        "unknown name 'bwol'",
    ),
    (
        "goal syntax",
        ('goal = "(and (On cube bowl))"', 'goal = "(and (On cube bowl)"'),
        "task.goal",
        "malformed PDDL",
    ),
    ("unknown field", ("x = 1.8", 'regoin = "x"\nx = 1.8'), "objects[0].regoin", "unknown field"),
    ("missing goal", ('[task]\ngoal = "(and (On cube bowl))"', ""), "task", "missing"),
    (
        "capacity",
        (
            'region = "table2_left"\nx = 4.2\ny = 4.45',
            'region = "table2_left"\nx = 4.2\ny = 4.45\n\n[[objects]]\nname = "mug"\n'
            'region = "microwave"\nx = 3.5\ny = 0.3\n\n[[objects]]\nname = "apple"\n'
            'region = "microwave"\nx = 3.9\ny = 0.3',
        ),
        "objects[3].region",
        "microwave is full: it holds mug",
    ),
    ("duplicate", ('name = "bowl"', 'name = "cube"'), "objects[1].name", "listed twice"),
    ("open not openable", "\n[open]\nsink = true\n", "open.sink", "sink cannot be opened"),
    ("robot in a table", "\n[robot]\nx = 1.5\ny = 4.0\n", "robot", "collides with table1"),
    (
        "belief object",
        '\n[[belief.objects]]\nname = "mug"\nunknown = true\n',
        "belief.objects[0].name",
        "not among the scenario's objects",
    ),
    (
        "belief region",
        '\n[[belief.objects]]\nname = "cube"\nregion = "shelf"\nx = 1\ny = 1\n',
        "belief.objects[0].region",
        "unknown region 'shelf'",
    ),
    (
        "disturbance",
        '\n[[noise.displace]]\nkind = "wobble"\n',
        "noise.displace[0].kind",
        "unknown disturbance 'wobble'",
    ),
]


@pytest.mark.parametrize(
    ("change", "field", "fragment"), [b[1:] for b in BAD], ids=[b[0] for b in BAD]
)
def test_bad_scenario_files(
    tmp_path: Path, change: tuple[str, str] | str, field: str, fragment: str
) -> None:
    if isinstance(change, tuple):
        old, new = change
        assert old in GOOD, old
        text = GOOD.replace(old, new, 1)
    else:
        text = GOOD + change
    path = tmp_path / "x.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {field}: "), message
    assert fragment in message, message
    assert isinstance(info.value, ValueError)


def test_the_good_file_loads(tmp_path: Path) -> None:
    path = tmp_path / "x.toml"
    path.write_text(GOOD + EVENT)
    s = load_scenario(path)
    assert s.source == str(path) and s.events[0].region == "table2_right"


def test_invalid_toml_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text("name = \n")
    with pytest.raises(ScenarioError, match=r"broken\.toml: invalid TOML"):
        load_scenario(path)
    with pytest.raises(ScenarioError, match=r"nothere\.toml: cannot read"):
        load_scenario(tmp_path / "nothere.toml")
    with pytest.raises(ScenarioError, match="unknown scenario"):
        builtin_scenario("no-such-scenario")
