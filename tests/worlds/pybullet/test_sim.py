"""The PyBullet simulation core: scene, camera/detection, IK, motion planning, pick and place."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("ompl")

from itertools import pairwise

from llmpas.worlds.pybullet.camera import detect, look_at, render
from llmpas.worlds.pybullet.kinematics import (
    Collision,
    forward,
    preserved,
    quat_angle,
    solve_ik,
    top_grasp_orientation,
)
from llmpas.worlds.pybullet.pybullet_motion import (
    BaseChecker,
    MotionConfig,
    base_line,
    grid_plan,
    interpolate,
    ompl_base_plan,
    plan_arm,
    plan_base,
)
from llmpas.worlds.pybullet.pybullet_values import ObjectPose
from llmpas.worlds.pybullet.scene import (
    HOME_CONF,
    TABLE_TOP,
    ObjectConfig,
    Scene,
    SceneConfig,
    TableConfig,
    open_scene,
)
from llmpas.worlds.pybullet.skills import Skills
from llmpas.worlds.pybullet.snapshot import is_blank, overview, save_gif, save_png

AT_TABLE1 = (0.55, 0.1, 0.0)  # base pose facing table1 (its near edge is at x = 1.1)
TABLE1_TOP = (1.3, 0.0, TABLE_TOP)


@pytest.fixture
def scene() -> Iterator[Scene]:
    with open_scene() as s:
        yield s


def add_wall(
    scene: Scene, name: str, half: tuple[float, float, float], at: tuple[float, ...]
) -> None:
    import pybullet as p

    c = scene.client
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=c)
    body = p.createMultiBody(0, shape, -1, list(at), physicsClientId=c)
    scene.bodies[name] = body
    scene.names[body] = name


# --------------------------------------------------------------------------- scene


def test_scene_loads_named_bodies_and_objects_rest_on_tables(scene: Scene) -> None:
    assert {"husky", "panda", "plane", "table1", "table2", "cube", "bowl"} <= set(scene.bodies)
    assert scene.base_pose() == pytest.approx((0.0, 0.0, 0.0), abs=1e-6)
    assert scene.arm_conf() == pytest.approx(HOME_CONF, abs=1e-3)
    cube, _ = scene.pose("cube")
    assert scene.tables["table1"].contains(cube[0], cube[1])
    assert cube[2] == pytest.approx(TABLE_TOP + 0.025, abs=0.005)  # resting, not sunk or flying
    bowl, _ = scene.pose("bowl")
    assert scene.tables["table2"].contains(bowl[0], bowl[1])


def test_moving_the_base_moves_the_mounted_arm(scene: Scene) -> None:
    before, _ = scene.ee_pose()
    scene.set_base(1.0, -0.5, math.pi / 2)
    after, _ = scene.ee_pose()
    assert scene.base_pose() == pytest.approx((1.0, -0.5, math.pi / 2), abs=1e-6)
    # the gripper turned with the base: its offset from the base rotated by 90 degrees
    assert after[:2] - np.array([1.0, -0.5]) == pytest.approx([-before[1], before[0]], abs=1e-3)
    assert after[2] == pytest.approx(before[2], abs=1e-6)


@pytest.mark.parametrize(
    "bad",
    [
        lambda: SceneConfig(tables=(TableConfig("t", 0, 0), TableConfig("t", 3, 0)), objects=()),
        lambda: SceneConfig(objects=(ObjectConfig("c", "cube", "nowhere", 0, 0),)),
        lambda: ObjectConfig("c", "sphere", "table1", 0, 0),
        lambda: ObjectConfig("c", "cube", "table1", 0, 0, colour="mauve"),
        lambda: TableConfig("t", 0, 0, yaw=0.3),
    ],
)
def test_invalid_configurations_are_rejected(bad: object) -> None:
    with pytest.raises(ValueError):
        bad()  # type: ignore[operator]


def test_two_scenes_live_in_separate_clients() -> None:
    with open_scene() as a, open_scene() as b:
        assert a.client != b.client
        a.set_base(1.0, 1.0, 0.0)
        assert b.base_pose() == pytest.approx((0.0, 0.0, 0.0), abs=1e-6)


# --------------------------------------------------------------------------- images


def test_overview_snapshot_is_not_blank_and_shows_the_scene(scene: Scene, tmp_path: Path) -> None:
    from PIL import Image as PILImage

    img = overview(scene)
    assert not is_blank(img.rgb)
    for name in ("cube", "bowl", "table1", "table2", "husky", "panda"):
        assert img.pixels_of(scene.bodies[name]) > 0, f"{name} not visible in the snapshot"
    path = save_png(img.rgb, tmp_path / "scene.png")
    with PILImage.open(path) as loaded:
        assert loaded.size == (img.rgb.shape[1], img.rgb.shape[0])
        assert not is_blank(np.asarray(loaded))
    assert is_blank(np.zeros_like(img.rgb))


def test_gif_has_all_frames(scene: Scene, tmp_path: Path) -> None:
    from PIL import Image as PILImage

    frames = []
    for x in (0.0, 0.3, 0.6):
        scene.set_base(x, 0.0, 0.0)
        frames.append(overview(scene).rgb)
    path = save_gif(frames, tmp_path / "episode.gif")
    with PILImage.open(path) as gif:
        assert gif.n_frames == 3


def test_detection_finds_the_cube_in_view_with_bounded_noise(scene: Scene) -> None:
    scene.set_base(*AT_TABLE1)
    truth, _ = scene.pose("cube")
    errors = []
    for seed in range(5):
        obs = detect(scene, look_at(scene, TABLE1_TOP), np.random.default_rng(seed))
        d = obs.find("cube")
        assert d is not None
        assert d.region == "table1"
        assert isinstance(d.pose, ObjectPose)
        errors.append(math.dist((d.pose.x, d.pose.y, d.pose.z), truth))
        assert "table1" in obs.viewed
        assert obs.find("bowl") is None  # table2 is behind the camera's field of view
    assert max(errors) < 0.03
    assert len({round(e, 6) for e in errors}) > 1  # the noise depends on the seed


def test_detection_is_reproducible_for_a_seed(scene: Scene) -> None:
    scene.set_base(*AT_TABLE1)
    img = look_at(scene, TABLE1_TOP)
    a = detect(scene, img, np.random.default_rng(7))
    b = detect(scene, img, np.random.default_rng(7))
    assert a == b


def test_an_object_out_of_view_is_not_detected(scene: Scene) -> None:
    scene.set_base(*AT_TABLE1)
    obs = detect(scene, look_at(scene, (-3.0, 0.1, 0.6)), np.random.default_rng(0))
    assert obs.find("cube") is None
    assert "table1" not in obs.viewed


def test_a_cube_in_the_bowl_is_detected_in_the_bowl(scene: Scene) -> None:
    bowl, _ = scene.pose("bowl")
    scene.set_pose("cube", (bowl[0], bowl[1], TABLE_TOP + 0.04))
    scene.settle()
    scene.set_base(-0.1, 0.85, math.pi / 2)
    obs = detect(scene, look_at(scene, (bowl[0], bowl[1], TABLE_TOP)), np.random.default_rng(0))
    d = obs.find("cube")
    assert d is not None and d.region == "bowl"


def test_render_has_depth_consistent_with_the_segmentation(scene: Scene) -> None:
    scene.set_base(*AT_TABLE1)
    img = render(scene, (0.6, 0.0, 1.2), TABLE1_TOP)
    table = img.seg == scene.bodies["table1"]
    pts = img.points(table)
    assert pts.shape[0] > 100
    assert np.median(pts[:, 2]) == pytest.approx(TABLE_TOP, abs=0.02)


# --------------------------------------------------------------------------- kinematics


def test_ik_reaches_poses_verified_by_forward_kinematics(scene: Scene) -> None:
    scene.set_base(*AT_TABLE1)
    rng = np.random.default_rng(0)
    orn = top_grasp_orientation(0.3)
    before = scene.arm_conf()
    for target in ((1.25, 0.1, 0.75), (1.2, -0.2, 0.9), (1.35, 0.3, 0.7)):
        q = solve_ik(scene, target, orn, rng)
        assert q is not None, target
        assert scene.arm_conf() == pytest.approx(before)  # planning does not move the arm
        with preserved(scene):
            pos, rot = forward(scene, q)
        assert np.linalg.norm(pos - np.array(target)) < 5e-3
        assert quat_angle(rot, orn) < 0.05


def test_ik_of_an_unreachable_pose_is_none(scene: Scene) -> None:
    q = solve_ik(scene, (3.0, 0.0, 0.7), top_grasp_orientation(), np.random.default_rng(0))
    assert q is None


def test_collision_check_sees_tables_and_ignores_the_mount(scene: Scene) -> None:
    col = Collision(scene)
    assert not col.collides(HOME_CONF)  # the Panda rests on the Husky: not a collision
    scene.set_base(*AT_TABLE1)
    q = solve_ik(
        scene, (1.3, 0.1, TABLE_TOP - 0.05), top_grasp_orientation(), np.random.default_rng(0)
    )
    if q is None:  # inside the table: IK may also just fail, then force a dive into it
        pytest.skip("no IK into the table top")
    assert col.collides(q)


def test_rrt_connect_finds_a_collision_free_path_around_an_obstacle(scene: Scene) -> None:
    scene.set_base(*AT_TABLE1)
    add_wall(scene, "wall", (0.12, 0.02, 0.2), (1.13, 0.1, 0.9))
    col = Collision(scene)
    rng = np.random.default_rng(1)
    a = solve_ik(scene, (1.1, -0.2, 0.8), top_grasp_orientation(), rng, valid=col)
    b = solve_ik(scene, (1.1, 0.4, 0.8), top_grasp_orientation(), rng, valid=col)
    assert a is not None and b is not None
    assert any(col.collides(q) for q in interpolate(a, b, 0.05)), "the wall must block"
    path = plan_arm(scene, a, b, col)
    assert path is not None
    assert path[0] == pytest.approx(a) and path[-1] == pytest.approx(b)
    assert not any(col.collides(q) for q in path)
    steps = [max(abs(x - y) for x, y in zip(u, v, strict=True)) for u, v in pairwise(path)]
    assert max(steps) <= 0.05 + 1e-9


def test_base_planner_drives_around_a_table(scene: Scene) -> None:
    checker = BaseChecker.of(scene)
    start, goal = (0.0, 0.0, 0.0), (2.65, 0.0, math.pi)
    assert not all(checker.free(q) for q in base_line(start, goal, 0.05))
    path = plan_base(checker, start, goal)
    assert path is not None
    assert path[0][:2] == pytest.approx(start[:2]) and path[-1][:2] == pytest.approx(goal[:2])
    assert all(checker.free(q) for q in path)
    assert max(math.dist(u[:2], v[:2]) for u, v in pairwise(path)) <= 0.05 + 1e-9


def test_base_detours_are_deterministic_and_ompl_se2_agrees(scene: Scene) -> None:
    checker = BaseChecker.of(scene)
    start, goal = (0.0, 0.0, 0.0), (1.34, 1.41, -math.pi / 2)  # between the two tables
    a = grid_plan(checker, start, goal, 0.05)
    assert a is not None and a == grid_plan(checker, start, goal, 0.05)
    assert all(checker.free(q) for q in a)
    b = ompl_base_plan(checker, start, goal, MotionConfig(timeout=5.0))
    assert b is not None
    assert all(checker.free(q) for q in b)
    assert b[-1][:2] == pytest.approx(goal[:2])


def test_base_planner_rejects_a_goal_inside_a_table(scene: Scene) -> None:
    assert plan_base(BaseChecker.of(scene), (0.0, 0.0, 0.0), (1.6, 0.0, 0.0)) is None


# --------------------------------------------------------------------------- skills


def test_pick_the_cube_and_place_it_in_the_bowl_with_physics(scene: Scene) -> None:
    rng = np.random.default_rng(3)
    skills = Skills(scene, rng)
    checker = BaseChecker.of(scene)
    path = plan_base(checker, scene.base_pose(), AT_TABLE1)
    assert path is not None
    skills.move_base(path)
    seen = detect(scene, look_at(scene, TABLE1_TOP), rng).find("cube")
    assert seen is not None
    assert skills.pick("cube", seen.pose)
    assert scene.held == "cube"
    cube, _ = scene.pose("cube")
    ee, _ = scene.ee_pose()
    assert np.linalg.norm(cube - ee) < 0.05  # in the hand, carried off the table
    assert not scene.tables["table1"].contains(cube[0], cube[1])

    path = plan_base(checker, scene.base_pose(), (-0.1, 0.85, math.pi / 2))
    assert path is not None
    skills.move_base(path)
    bowl_seen = detect(scene, look_at(scene, (0.0, 1.6, TABLE_TOP)), rng).find("bowl")
    assert bowl_seen is not None
    b = bowl_seen.pose
    assert skills.place(ObjectPose("bowl", b.x, b.y, TABLE_TOP + 0.01 + 0.025))
    assert scene.held is None
    scene.settle(240)
    cube, _ = scene.pose("cube")
    bowl, _ = scene.pose("bowl")
    inner = 0.16 / 2 - 0.01
    assert abs(cube[0] - bowl[0]) < inner - 0.02 and abs(cube[1] - bowl[1]) < inner - 0.02
    assert cube[2] == pytest.approx(TABLE_TOP + 0.01 + 0.025, abs=0.01)  # resting on its bottom


def test_closing_on_nothing_is_not_a_grasp(scene: Scene) -> None:
    skills = Skills(scene, np.random.default_rng(0))
    assert not skills.close("cube")
    assert scene.held is None


def test_rrt_connect_plans_the_same_path_whatever_ran_before(scene: Scene) -> None:
    """OMPL seeds itself from the clock: unseeded, the same query drew other paths in every
    process (a recorded prompt that counts the alternatives explored then missed its cassette)."""
    scene.set_base(*AT_TABLE1)
    add_wall(scene, "wall", (0.12, 0.02, 0.2), (1.13, 0.1, 0.9))
    col = Collision(scene)
    rng = np.random.default_rng(1)
    a = solve_ik(scene, (1.1, -0.2, 0.8), top_grasp_orientation(), rng, valid=col)
    b = solve_ik(scene, (1.1, 0.4, 0.8), top_grasp_orientation(), rng, valid=col)
    c = solve_ik(scene, (1.0, 0.3, 0.7), top_grasp_orientation(), rng, valid=col)
    assert a is not None and b is not None and c is not None
    config = MotionConfig(resolution=0.05)
    first = plan_arm(scene, a, b, col, config)
    plan_arm(scene, c, a, col, config)  # another query in between draws random numbers
    assert first is not None and plan_arm(scene, a, b, col, config) == first
