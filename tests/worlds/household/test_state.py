"""The true state: queries, changes and snapshots."""

from __future__ import annotations

import dataclasses

import pytest

from llmpas.worlds.household.household_values import BaseConf, Placement
from llmpas.worlds.household.layout import default_objects, kitchen
from llmpas.worlds.household.state import (
    TrueState,
    base_collision,
    point_rect_distance,
    segment_rect_distance,
)

from .support import scenario


def state_with(*objects: dict[str, object], **open_: bool) -> TrueState:
    return scenario(objects=list(objects), open=open_, task={"goal": "(and)"}).initial_state(
        kitchen()
    )


def test_geometry_helpers() -> None:
    rect = (0.0, 0.0, 1.0, 1.0)
    assert point_rect_distance(0.5, 0.5, rect) == 0.0
    assert point_rect_distance(2.0, 0.5, rect) == pytest.approx(1.0)
    assert point_rect_distance(2.0, 2.0, rect) == pytest.approx(2**0.5)
    assert segment_rect_distance(-1.0, 0.5, 2.0, 0.5, rect) == 0.0  # straight through
    assert segment_rect_distance(-1.0, 1.5, 2.0, 1.5, rect) == pytest.approx(0.5)  # above
    assert segment_rect_distance(2.0, 0.0, 0.0, 2.0, rect) == pytest.approx(0.0, abs=1e-12)
    assert segment_rect_distance(3.0, 0.0, 0.0, 3.0, rect) == pytest.approx((2**0.5) / 2)
    layout = kitchen()
    assert base_collision(layout, *layout.home[:2]) is None
    assert base_collision(layout, 1.5, 4.0) == "table1"
    assert base_collision(layout, 0.1, 4.0) == "the wall"


def test_regions_contents_and_capacity() -> None:
    s = state_with(
        {"name": "mug", "region": "microwave", "x": 3.75, "y": 0.3},
        {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
        {"name": "black_cube", "inside": "bowl"},
        {"name": "cube", "region": "table2_left", "x": 4.2, "y": 4.7},
    )
    assert s.objects_in("microwave") == ("mug",)
    assert s.objects_in("table2_left") == ("bowl", "cube")
    assert s.objects_in("bowl") == ("black_cube",)
    assert s.occupied("microwave") and s.occupied("bowl")
    assert not s.occupied("table2_left")  # no capacity: only geometry limits it
    assert not s.occupied("drawer1")
    assert s.capacity("drawer1") == 2 and s.capacity("bowl") == 1
    assert s.is_region("bowl") and not s.is_region("cube")
    assert "bowl" in s.regions()


def test_free_at_uses_footprints() -> None:
    s = state_with({"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45})
    r_bowl, r_cube = 0.09, 0.03
    assert not s.free_at("table2_left", 4.2 + r_bowl + r_cube - 0.01, 4.45, r_cube)
    assert s.free_at("table2_left", 4.2 + r_bowl + r_cube + 0.01, 4.45, r_cube)
    assert s.free_at("table2_left", 4.2, 4.45, r_cube, ignore=("bowl",))
    assert s.free_at("table1_left", 4.2, 4.45, r_cube)  # other regions do not count
    assert s.overlapping("table2_left", 4.25, 4.45, r_cube) == ("bowl",)


def test_accessibility() -> None:
    s = state_with(
        {"name": "basket", "region": "table1_left", "x": 1.2, "y": 4.5},
        {"name": "bowl", "under": "basket"},
        {"name": "cube", "region": "drawer1", "x": 0.25, "y": 1.85},
        fridge=True,
    )
    assert not s.accessible("drawer1") and s.inaccessible_reason("drawer1") == "drawer1 is closed"
    assert s.accessible("fridge") and s.accessible("table1_left") and s.accessible("sink")
    assert not s.accessible("bowl")
    assert s.inaccessible_reason("bowl") == "bowl is covered by basket"
    assert not s.visible("bowl") and s.visible("basket")
    s.open["drawer1"] = True
    assert s.accessible("drawer1")


def test_take_and_put_carry_contents_and_uncover() -> None:
    s = state_with(
        {"name": "bowl", "region": "table2_left", "x": 4.2, "y": 4.45},
        {"name": "cube", "inside": "bowl"},
        {"name": "basket", "region": "table1_left", "x": 1.2, "y": 4.5},
        {"name": "apple", "under": "basket"},
    )
    s.take("bowl")
    assert s.held == "bowl" and "bowl" not in s.placements
    assert s.carried("cube") and s.position("cube") is None and not s.visible("cube")
    s.put("bowl", Placement("table2_right", 4.8, 4.5))
    assert s.held is None
    assert s.placements["cube"] == Placement("bowl", 4.8, 4.5)
    s.take("basket")  # lifting the basket uncovers the apple
    assert s.covered == {} and s.visible("apple")
    with pytest.raises(ValueError, match="the hand holds basket"):
        s.take("cube")
    s.put("basket", Placement("table1_left", 1.2, 4.5))
    assert s.covered == {} and s.held is None


def test_snapshot_is_frozen_and_independent() -> None:
    s = state_with({"name": "cube", "region": "table1_right", "x": 1.8, "y": 4.45})
    snap = s.snapshot()
    s.take("cube")
    s.base = BaseConf(1.0, 1.0, 0.0)
    assert snap.region_of("cube") == "table1_right" and snap.held is None
    assert snap.base == BaseConf(*kitchen().home)
    with pytest.raises(TypeError):
        snap.placements["cube"] = Placement("sink", 1.0, 0.3)  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        snap.held = "cube"  # type: ignore[misc]
    assert s.snapshot() != snap
    assert "cube at table1_right@(1.80,4.45)" in snap.describe()


def test_properties_default_from_the_catalogue() -> None:
    specs = dict(default_objects())
    specs["apple"] = dataclasses.replace(specs["apple"], properties=frozenset({"dirty"}))
    s = TrueState(kitchen(), specs, BaseConf(3.0, 2.5, 0.0))
    s.put("apple", Placement("table1_left", 1.2, 4.45))
    assert s.properties["apple"] == {"dirty"}
    assert all(not v for v in s.open.values()) and "drawer3" in s.open
