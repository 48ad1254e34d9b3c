"""The household simulator: perception, skills, noise and injected events."""

from __future__ import annotations

import math

import numpy as np
import pytest

from llmpas.execution.robot_protocols import Observation, Perception, Robot
from llmpas.worlds.household.household_values import BaseConf, Motion, Placement
from llmpas.worlds.household.layout import kitchen
from llmpas.worlds.household.scenario import builtin_scenario
from llmpas.worlds.household.sim import HouseholdWorld

from .support import (
    AT_CABINET,
    AT_FRIDGE,
    AT_MICROWAVE,
    AT_SINK,
    AT_STOVE,
    AT_TABLE1,
    AT_TABLE2,
    DOWN,
    TOP,
    UP,
    at,
    pick,
    true_xy,
    world,
)

CUBE_IN_DRAWER = [
    {"name": "cube", "region": "drawer2", "x": 0.25, "y": 2.35},
    {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
]
CUBE_UNDER_BASKET = [
    {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
    {"name": "basket", "region": "table2_right", "x": 4.8, "y": 4.5},
    {"name": "cube", "under": "basket"},
]


def shipped(name: str, seed: int = 0) -> HouseholdWorld:
    return HouseholdWorld(kitchen(), builtin_scenario(name), np.random.default_rng(seed))


def seen(obs: Observation) -> dict[str, str]:
    return {d.obj: d.region for d in obs.detections}


def test_the_world_is_a_robot_and_a_perception() -> None:
    w = world()
    assert isinstance(w, Robot) and isinstance(w, Perception)
    assert w.holding() is None
    assert w.base_conf() == w.scenario.robot


# ---------------------------------------------------------------------------- perception


def test_look_along_the_heading_sees_the_tables_not_the_counter() -> None:
    w = world()
    obs = w.look()
    assert {"table1_right", "table2_left", "bowl"} <= set(obs.viewed)
    assert "sink" not in obs.viewed and "drawer1" not in obs.viewed  # behind / closed
    assert seen(obs) == {"cube": "table1_right", "bowl": "table2_left"}
    w.move_base(BaseConf(3.0, 2.5, DOWN))
    obs = w.look()
    assert {"sink", "stove"} <= set(obs.viewed) and "table1_right" not in obs.viewed
    assert "microwave" not in obs.viewed  # closed


def test_look_at_a_target_turns_the_camera_not_the_base() -> None:
    w = world()
    w.move_base(BaseConf(3.0, 2.5, DOWN))
    obs = w.look("table1_right")
    assert obs.viewed == ("table1_right",)
    assert seen(obs) == {"cube": "table1_right"}
    assert w.base_conf().theta == DOWN and w.truth.base.theta == DOWN
    assert w.camera_heading == pytest.approx(math.atan2(4.6 - 2.5, 1.8 - 3.0))
    assert set(w.look("table2").viewed) == {"table2_left", "table2_right", "bowl"}
    with pytest.raises(ValueError, match="unknown 'attic'"):
        w.look("attic")


def test_look_respects_the_camera_range() -> None:
    w = world(
        objects=[
            {"name": "cube", "region": "table1_right", "x": 1.8, "y": 4.45},
            {"name": "bowl", "region": "table2_right", "x": 4.8, "y": 4.45},
        ]
    )
    assert w.move_base(AT_TABLE1).ok
    far = w.look("table2_right")  # more than 3 m away
    assert far.viewed == () and far.detections == ()
    assert w.look("table2").viewed == ("table2_left",)  # the nearer half is in range
    near = w.look("table1_right")
    assert near.viewed == ("table1_right",) and seen(near) == {"cube": "table1_right"}


def test_covered_objects_are_hidden_and_the_cover_is_seen() -> None:
    w = world(objects=CUBE_UNDER_BASKET, task={"goal": "(On cube bowl)"})
    w.move_base(AT_TABLE2)
    assert seen(w.look("table2")) == {"bowl": "table2_left", "basket": "table2_right"}
    pick(w, "basket")  # lifting the basket uncovers the cube
    assert w.holding() == "basket"
    assert seen(w.look("table2")) == {"bowl": "table2_left", "cube": "table2_right"}
    # putting it back over the cube covers it again; half over it is blocked
    w.move_arm(at(4.8, 4.5 + 0.15))
    r = w.release("basket", Placement("table2_right", 4.8, 4.5 + 0.15))
    assert not r.ok and r.message == "the placement on table2_right is blocked by cube"
    w.move_arm(at(4.82, 4.5))
    assert w.release("basket", Placement("table2_right", 4.82, 4.5)).ok
    assert w.truth.covered == {"cube": "basket"}
    assert seen(w.look("table2")) == {"bowl": "table2_left", "basket": "table2_right"}


def test_closed_drawers_hide_their_contents_until_opened() -> None:
    w = world(objects=CUBE_IN_DRAWER)
    assert w.move_base(AT_CABINET).ok
    obs = w.look("drawer2")
    assert obs.viewed == () and obs.find("cube") is None
    assert w.open("drawer2").ok
    obs = w.look("drawer2")
    assert obs.viewed == ("drawer2",)
    d = obs.find("cube")
    assert d is not None and d.region == "drawer2" and isinstance(d.pose, Placement)
    assert w.close("drawer2").ok and w.look("drawer2").viewed == ()


def test_receptacle_contents_are_seen_with_the_receptacle() -> None:
    w = shipped("action-blocking-bowl")
    obs = w.look("table2_left")
    assert obs.viewed == ("table2_left", "bowl")
    assert seen(obs) == {"bowl": "table2_left", "black_cube": "bowl"}
    assert obs.in_region("bowl")[0].pose.region == "bowl"


def test_misdetections_and_pose_noise_follow_the_scenario() -> None:
    noise = {"miss_prob": 0.3, "pose_sigma": 0.02}
    w = world(seed=11, noise=noise)
    hits = []
    for _ in range(2000):
        d = w.look("table1_right").find("cube")
        if d is not None:
            hits.append((d.pose.x, d.pose.y))
    rate = len(hits) / 2000
    assert abs(rate - 0.7) < 0.04
    xs = np.array(hits)
    assert np.allclose(xs.mean(axis=0), (1.8, 4.45), atol=0.004)
    assert np.allclose(xs.std(axis=0), 0.02, rtol=0.1)
    # the same seed replays the same detections
    a, b = world(seed=5, noise=noise), world(seed=5, noise=noise)
    assert [a.look() for _ in range(10)] == [b.look() for _ in range(10)]


def test_detections_report_visible_properties() -> None:
    w = world(
        objects=[
            {
                "name": "apple",
                "region": "table1_left",
                "x": 1.2,
                "y": 4.45,
                "properties": ["dirty", "cooked"],
            }
        ],
        task={"goal": "(Cooled apple)"},
    )
    d = w.look("table1_left").find("apple")
    assert d is not None and d.properties == {"dirty", "cooked"}


# ------------------------------------------------------------------------------ the base


def test_move_base_is_blocked_by_a_table() -> None:
    w = world()
    r = w.move_base(BaseConf(1.5, 5.5, 0.0))  # straight through table1
    assert not r.ok and r.message == "path blocked by table1"
    assert r.data["reason"] == "blocked"
    r = w.move_base(BaseConf(1.5, 4.0, UP))  # the pose itself is in the table
    assert not r.ok and r.message.startswith("path blocked by table1")
    assert w.base_conf() == w.scenario.robot and w.truth.base == w.scenario.robot
    # around it, through way points
    assert w.move_base(
        Motion((BaseConf(3.0, 2.5, UP), BaseConf(3.0, 5.5, UP), BaseConf(1.5, 5.5, 0.0)))
    ).ok
    assert w.base_conf() == BaseConf(1.5, 5.5, 0.0)


def test_odometry_noise_is_seeded_and_reproducible() -> None:
    def run(seed: int) -> list[BaseConf]:
        w = world(seed=seed, noise={"base_sigma": 0.02})
        out = []
        for goal in (AT_TABLE1, AT_TABLE2, AT_FRIDGE):
            assert w.move_base(goal).ok
            assert w.base_conf() == goal  # the robot believes it is where it was sent
            out.append(w.truth.base)
        return out

    first, again, other = run(3), run(3), run(4)
    assert first == again and first != other
    goals = (AT_TABLE1, AT_TABLE2, AT_FRIDGE)
    errors = [math.hypot(q.x - g.x, q.y - g.y) for q, g in zip(first, goals, strict=True)]
    assert all(0 < e < 0.1 for e in errors)
    w = world()  # no noise: exactly there
    assert w.move_base(AT_TABLE1).ok and w.truth.base == AT_TABLE1


def test_the_arm_reaches_from_the_true_base() -> None:
    w = world()
    r = w.move_arm(at(1.8, 4.45))
    assert not r.ok and r.message.startswith("out of reach") and r.data["reason"] == "out_of_reach"
    w.move_base(AT_TABLE1)
    assert w.move_arm(at(1.8, 4.45)).ok
    # 0.9 m from where the robot believes it is, but the base truly stands 0.2 m further back
    w.truth.base = BaseConf(AT_TABLE1.x, AT_TABLE1.y - 0.2, UP)
    assert w.base_conf() == AT_TABLE1
    assert w.move_arm(at(AT_TABLE1.x, AT_TABLE1.y + 0.9)).data["reason"] == "out_of_reach"


# ------------------------------------------------------------------------- grasp, release


def test_grasp_fails_off_target_and_succeeds_at_the_true_position() -> None:
    w = world()
    w.move_base(AT_TABLE1)
    w.move_arm(at(1.8 + 0.08, 4.45))
    r = w.grasp("cube", TOP)
    assert not r.ok and r.message == "nothing to grasp at the target"
    w.move_arm(at(1.8 + 0.05, 4.45, phase="pre"))
    assert w.grasp("cube", TOP).data["reason"] == "arm_not_ready"
    w.move_arm(at(1.8 + 0.05, 4.45))  # within 0.03 m + the cube's radius
    r = w.grasp("cube", TOP)
    assert r.ok and w.holding() == "cube" and "cube" not in w.truth.placements
    assert w.look("table1_right").find("cube") is None
    assert w.grasp("bowl", TOP).message.startswith("the hand is not empty")


def test_grasp_in_a_closed_drawer_and_under_a_cover() -> None:
    w = world(objects=CUBE_IN_DRAWER)
    w.move_base(AT_CABINET)
    w.move_arm(at(0.25, 2.35))
    r = w.grasp("cube", TOP)
    assert not r.ok and r.message == "drawer2 is closed" and r.data["reason"] == "closed"
    w.open("drawer2")
    w.move_arm(at(0.25, 2.35))
    assert w.grasp("cube", TOP).ok

    w = world(objects=CUBE_UNDER_BASKET, task={"goal": "(On cube bowl)"})
    w.move_base(AT_TABLE2)
    w.move_arm(at(4.8, 4.5))
    r = w.grasp("cube", TOP)
    assert not r.ok and r.message == "cube is covered by basket"


def test_slips_scripted_and_random() -> None:
    w = world(noise={"displace": [{"kind": "slip", "attempt": 1}]})
    w.move_base(AT_TABLE1)
    w.move_arm(at(1.8, 4.45))
    r = w.grasp("cube", TOP)
    assert not r.ok and r.message == "the object slipped" and w.holding() is None
    assert w.grasp("cube", TOP).ok
    assert [e.name for e in w.fired()] == ["slip"]

    slips = 0
    w = world(seed=2, noise={"slip_prob": 0.5})
    w.move_base(AT_TABLE1)
    w.move_arm(at(1.8, 4.45))
    for _ in range(400):
        if w.grasp("cube", TOP).ok:
            w.release("cube", Placement("table1_right", 1.8, 4.45))
        else:
            slips += 1
    assert 160 < slips < 240


def test_release_checks_the_gripper_region_and_overlap() -> None:
    w = world()
    w.move_base(AT_TABLE1)
    pick(w, "cube")
    r = w.release("cube", Placement("table1_right", 1.8, 4.7))
    assert not r.ok and r.message == "the gripper is not at the placement"
    w.move_arm(at(1.8, 4.7))
    assert w.release("cube", Placement("table1_right", 1.8, 4.7)).ok
    assert w.truth.placements["cube"] == Placement("table1_right", 1.8, 4.7)
    assert w.holding() is None
    assert w.release("cube", Placement("table1_right", 1.8, 4.7)).data["reason"] == "not_held"

    w = world(
        objects=[
            {"name": "cube", "region": "table1_right", "x": 1.8, "y": 4.45},
            {"name": "mug", "region": "table1_left", "x": 1.3, "y": 4.45},
        ],
        task={"goal": "(On cube table1_left)"},
    )
    w.move_base(AT_TABLE1)
    pick(w, "cube")
    w.move_arm(at(1.34, 4.45))
    r = w.release("cube", Placement("table1_left", 1.34, 4.45))
    assert not r.ok and r.message == "the placement on table1_left is blocked by mug"
    w.move_arm(at(1.49, 4.45))
    r = w.release("cube", Placement("table1_left", 1.49, 4.45))  # the rim would hang over
    assert not r.ok and r.data["reason"] == "outside"


def test_capacity_blocks_release_into_the_occupied_microwave() -> None:
    w = shipped("action-blocking-microwave")
    assert w.move_base(BaseConf(1.2, 3.8, UP)).ok
    pick(w, "bread")
    assert w.move_base(AT_MICROWAVE).ok
    assert w.open("microwave").ok
    w.move_arm(at(3.5, 0.3))
    r = w.release("bread", Placement("microwave", 3.5, 0.3))
    assert not r.ok and r.message == "microwave is occupied by mug"
    assert r.data["reason"] == "occupied" and w.holding() == "bread"


def test_the_occupied_bowl_blocks_the_cube() -> None:
    w = shipped("action-blocking-bowl")
    w.move_base(AT_TABLE1)
    pick(w, "cube")
    w.move_base(AT_TABLE2)
    w.move_arm(at(4.2, 4.45))
    r = w.release("cube", Placement("bowl", 4.2, 4.45))
    assert not r.ok and r.message == "bowl is occupied by black_cube"


def test_objects_in_a_carried_bowl_move_with_it() -> None:
    w = world(
        objects=[
            {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
            {"name": "cube", "inside": "bowl"},
        ]
    )
    w.move_base(AT_TABLE2)
    pick(w, "bowl")
    assert w.truth.carried("cube")
    w.move_arm(at(4.8, 4.5))
    assert w.release("bowl", Placement("table2_right", 4.8, 4.5)).ok
    assert w.truth.placements["cube"] == Placement("bowl", 4.8, 4.5)
    assert seen(w.look("table2_right")) == {"bowl": "table2_right", "cube": "bowl"}


# ------------------------------------------------------------------------------- events


def test_events_fire_at_the_right_skill_count_and_change_what_look_reports() -> None:
    w = shipped("object-loss-table")
    assert seen(w.look())["cube"] == "table1_right"
    assert not w.move_base(BaseConf(1.5, 4.0, UP)).ok  # failures do not count
    assert w.truth.placements["cube"].region == "table1_right"
    assert w.move_base(AT_TABLE1).ok  # the first successful drive
    assert w.truth.placements["cube"] == Placement("table2_right", 4.8, 4.5)
    assert w.look("table1_right").find("cube") is None
    (event,) = w.fired()
    assert event.kind == "event" and event.ok and "table2_right" in event.message
    assert w.move_base(BaseConf(3.0, 2.5, UP)).ok
    assert seen(w.look())["cube"] == "table2_right"
    assert len(w.fired()) == 1  # only once


def test_object_loss_into_the_closed_drawer() -> None:
    w = shipped("object-loss-drawer")
    assert w.move_base(AT_CABINET).ok
    assert w.truth.placements["cube"].region == "drawer2"
    assert w.look("drawer2").find("cube") is None
    w.open("drawer2")
    assert w.look("drawer2").find("cube") is not None


def test_object_loss_under_the_basket() -> None:
    w = shipped("object-loss-basket")
    assert w.move_base(AT_TABLE2).ok
    assert w.truth.covered == {"cube": "basket"}
    assert seen(w.look("table2")) == {"bowl": "table2_left", "basket": "table2_right"}


def test_occupy_and_nudge_events() -> None:
    w = world(
        events=[
            {
                "after": {"skill": "look", "count": 1},
                "type": "occupy",
                "object": "black_cube",
                "into": "bowl",
            },
        ],
        noise={
            "displace": [
                {
                    "kind": "nudge",
                    "object": "cube",
                    "dx": 0.05,
                    "dy": 0.0,
                    "after": {"skill": "look", "count": 2},
                }
            ]
        },
    )
    assert "black_cube" not in seen(w.look())
    assert seen(w.look())["black_cube"] == "bowl"
    assert w.truth.placements["cube"] == Placement("table1_right", 1.85, 4.45)
    assert [e.name for e in w.fired()] == ["occupy", "nudge"]


def test_state_change_apple_dirty_after_grasp_and_processes() -> None:
    w = shipped("state-change-apple")
    w.move_base(BaseConf(1.2, 3.8, UP))
    assert "dirty" not in w.truth.properties["apple"]
    pick(w, "apple")
    assert "dirty" in w.truth.properties["apple"]  # fired inside the first grasp
    # into the fridge: cooling a dirty apple fails
    w.move_base(AT_FRIDGE)
    w.open("fridge")
    w.move_arm(at(5.5, 2.1))
    assert w.release("apple", Placement("fridge", 5.5, 2.1)).ok
    r = w.process("apple", "fridge", "cool")
    assert not r.ok and r.message == "fridge is open"
    w.close("fridge")
    r = w.process("apple", "fridge", "cool")
    assert not r.ok and r.data["reason"] == "dirty"
    w.open("fridge")
    d = w.look("fridge").find("apple")
    assert d is not None and "dirty" in d.properties
    pick(w, "apple")
    # wash it in the sink
    w.move_base(AT_SINK)
    assert not w.process("apple", "sink", "clean").ok  # still in the hand
    w.move_arm(at(1.15, 0.3))
    assert w.release("apple", Placement("sink", 1.15, 0.3)).ok
    assert w.process("apple", "sink", "heat").message == "sink cannot heat (it can clean)"
    assert w.process("apple", "sink", "clean").ok
    assert w.truth.properties["apple"] == {"cleaned"}
    pick(w, "apple")
    w.move_base(AT_FRIDGE)
    w.move_arm(at(5.5, 2.1))
    assert w.release("apple", Placement("fridge", 5.5, 2.1)).ok
    w.close("fridge")
    assert w.process("apple", "fridge", "cool").ok
    assert w.truth.properties["apple"] == {"cleaned", "cooled"}


def test_cook_and_heat() -> None:
    w = world(
        objects=[
            {"name": "bread", "region": "stove", "x": 2.35, "y": 0.3},
            {"name": "mug", "region": "microwave", "x": 3.75, "y": 0.3},
        ],
        task={"goal": "(and (Cooked bread) (Heated mug))"},
    )
    assert w.process("bread", "stove", "cook").ok
    assert "cooked" in w.truth.properties["bread"]
    assert w.process("mug", "microwave", "heat").ok  # closed: fine
    assert "heated" in w.truth.properties["mug"]
    assert w.process("mug", "stove", "cook").message == "mug is not in stove"
    assert w.move_base(AT_STOVE).ok
    assert w.open("microwave").data["reason"] == "out_of_reach"  # 1 m away
    assert w.move_base(AT_MICROWAVE).ok
    assert w.open("microwave").ok and w.open("microwave").message == "microwave is already open"
    assert not w.open("sink").ok
    w.move_base(AT_TABLE2)
    assert w.close("microwave").data["reason"] == "out_of_reach"


def test_the_log_records_skills_in_order() -> None:
    w = world()
    w.look()
    w.move_base(AT_TABLE1)
    w.move_arm(at(0.0, 0.0))
    assert [(e.name, e.ok) for e in w.skill_calls()] == [
        ("look", True),
        ("move_base", True),
        ("move_arm", False),
    ]
    assert w.successes("move_base") == 1
    assert "out of reach" in str(w.log[-1])


def _check_invariants(w: HouseholdWorld) -> None:
    t = w.truth
    assert set(t.objects) == set(t.specs)
    assert t.held is None or t.held not in t.placements
    for region in t.regions():
        objs = [o for o in t.objects_in(region) if o not in t.covered]
        cap = t.capacity(region)
        assert cap is None or len(t.objects_in(region)) <= cap, region
        for i, a in enumerate(objs):
            for b in objs[i + 1 :]:
                pa, pb = t.placements[a], t.placements[b]
                assert math.hypot(pa.x - pb.x, pa.y - pb.y) >= t.radius(a) + t.radius(b) - 1e-6
    for obj, cover in t.covered.items():
        assert t.placements[obj].region == t.placements[cover].region
    for obj, rec in t.inside.items():
        assert t.placements[obj].region == rec


def test_random_skill_sequences_keep_the_true_state_consistent() -> None:
    rng = np.random.default_rng(0)
    w = world(
        seed=1,
        objects=[
            {"name": "cube", "region": "table1_right", "x": 1.8, "y": 4.45},
            {"name": "apple", "region": "table1_left", "x": 1.2, "y": 4.45},
            {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
            {"name": "basket", "region": "table2_right", "x": 4.8, "y": 4.5},
            {"name": "mug", "under": "basket"},
        ],
        noise={"pose_sigma": 0.01, "base_sigma": 0.01, "miss_prob": 0.1, "slip_prob": 0.2},
    )
    bases = [AT_TABLE1, AT_TABLE2, BaseConf(1.2, 3.8, UP)]
    spots = [
        Placement("table1_right", 1.8, 4.45),
        Placement("table1_left", 1.2, 4.45),
        Placement("table2_left", 4.2, 4.45),
        Placement("table2_right", 4.8, 4.5),
        Placement("table2_right", 4.8, 4.75),
        Placement("bowl", 4.2, 4.45),
    ]
    for _ in range(1000):
        k = rng.integers(4)
        if k == 0:
            w.move_base(bases[rng.integers(len(bases))])
        elif k == 1 and w.holding() is None:
            objs = [o for o in w.truth.placements if w.truth.position(o) is not None]
            obj = objs[rng.integers(len(objs))]
            x, y = true_xy(w, obj)
            w.move_arm(at(x + rng.normal(0, 0.02), y + rng.normal(0, 0.02)))
            w.grasp(obj, TOP)
        elif k == 2 and w.holding() is not None:
            spot = spots[rng.integers(len(spots))]
            if spot.region == "bowl":
                pos = w.truth.position("bowl")
                if pos is None:
                    continue
                spot = Placement("bowl", *pos)
            w.move_arm(at(spot.x, spot.y))
            w.release(w.holding() or "", spot)
        else:
            w.look()
        _check_invariants(w)
    assert w.successes("grasp") > 15 and w.successes("release") > 15
    assert any(e.name == "slip" for e in w.fired())
