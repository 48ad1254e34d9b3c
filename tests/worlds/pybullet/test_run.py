"""The PyBullet world plugged into the planner and the CSubBT executor (no LLM)."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("ompl")

from llmpas.execution.executor import ExecStatus
from llmpas.language.logic import Atom, Not
from llmpas.system import LoopResult, run_once
from llmpas.worlds.api import RunOptions
from llmpas.worlds.pybullet.pybullet_motion import BaseChecker
from llmpas.worlds.pybullet.pybullet_plugin import WORLD
from llmpas.worlds.pybullet.pybullet_problem import static_facts
from llmpas.worlds.pybullet.pybullet_robot import PyBulletWorld
from llmpas.worlds.pybullet.pybullet_scenarios import PyBulletScenario, scenarios
from llmpas.worlds.pybullet.pybullet_streams import Geometry, make_streams
from llmpas.worlds.pybullet.pybullet_values import BaseConf, BasePath, Grasp, ObjectPose
from llmpas.worlds.pybullet.scene import TABLE_TOP, SceneConfig, open_scene
from llmpas.worlds.pybullet.snapshot import is_blank


class Once:
    """One plan executed without reasoning (:func:`llmpas.system.run_once`), judged in the truth."""

    def __init__(self, result: LoopResult) -> None:
        self.plan = result.rounds[0].plan
        self.episode = result.rounds[0].episode
        self.achieved = result.success


def once(name: str, options: RunOptions | None = None, out: Path | None = None) -> Once:
    return Once(run_once(WORLD, name, options or RunOptions(snapshots=False), out))


def test_nominal_completes_end_to_end_and_writes_an_episode_folder(tmp_path: Path) -> None:
    from PIL import Image as PILImage

    run = once("nominal", RunOptions(), out=tmp_path)
    assert run.plan.plan is not None
    assert [s.action for s in run.plan.plan.steps] == ["move_base", "pick", "move_base", "place"]
    assert run.episode is not None and run.episode.status is ExecStatus.SUCCESS
    assert run.achieved  # judged in the true state: the cube rests in the bowl
    for name in ("episode.json", "report.md", "report.html", "plan.xml", "run.json"):
        assert (tmp_path / name).is_file(), name
    shots = sorted((tmp_path / "snapshots").glob("*.png"))
    assert len(shots) >= 4
    for shot in (shots[0], shots[-1]):
        with PILImage.open(shot) as img:
            assert not is_blank(np.asarray(img))
    with PILImage.open(tmp_path / "episode.gif") as gif:
        assert 4 <= gif.n_frames <= len(shots)  # Pillow merges identical consecutive frames
    assert any((tmp_path / "camera").glob("*wrist*.png"))  # the approach used the wrist camera


def test_object_loss_ends_in_an_anomaly_naming_the_lost_cube() -> None:
    run = once("object-loss")
    assert run.episode is not None and run.episode.status is ExecStatus.ANOMALY
    report = run.episode.anomaly
    assert report is not None
    assert report.constraint == Atom("on", ("cube", "table1"))
    assert report.sub_action == "locate"
    assert report.failures["Detected"] >= 2  # the search looked from more than one base pose
    # the search moved the arm (wrist camera) before moving the base
    assert any("arm" in v for v in report.explored.get("camera", ()))
    assert len(report.explored.get("view_base", ())) >= 2
    assert not run.achieved


def test_action_blocking_seen_ends_in_an_anomaly_naming_the_full_bowl() -> None:
    run = once("action-blocking-seen")
    assert run.episode is not None and run.episode.status is ExecStatus.ANOMALY
    report = run.episode.anomaly
    assert report is not None
    assert report.constraint == Not(Atom("full", ("bowl",)))
    assert Atom("holding", ("cube",)) not in run.episode.belief  # derived; check the grasp
    assert any(a.predicate == "atgrasp" and a.args[0] == "cube" for a in run.episode.belief)
    # the robot saw the black cube in the bowl
    assert any(
        a.predicate == "supported" and a.args[0] == "black_cube" and a.args[2] == "bowl"
        for a in run.episode.belief
    )


def test_scenarios_are_valid_and_named() -> None:
    known = scenarios()
    assert {"nominal", "object-loss", "action-blocking", "action-blocking-seen"} <= set(known)
    with pytest.raises(ValueError):
        PyBulletScenario("bad", "", SceneConfig(), "(and (On cube bowl))", unknown=("ghost",))
    with pytest.raises(KeyError):
        once("no-such-scenario")


# --------------------------------------------------------------------------- streams


def test_streams_produce_real_geometry() -> None:
    with open_scene() as scene:
        geometry = Geometry(scene, np.random.default_rng(0))
        cube = ObjectPose("table1", 1.27, 0.15, TABLE_TOP + 0.025)
        bowl = ObjectPose("table2", -0.1, 1.6, TABLE_TOP)
        located = {"cube": cube, "bowl": bowl}
        streams = make_streams(geometry, located.get, lambda: BaseConf(0.0, 0.0, 0.0))

        poses = list(itertools.islice(streams["sample-pose"].fn("cube", "table2"), 5))
        for (p,) in poses:
            assert scene.tables["table2"].contains(p.x, p.y, margin=0.09)
            assert p.z == pytest.approx(TABLE_TOP + 0.025)
        ((into,),) = list(streams["sample-pose"].fn("cube", "bowl"))
        assert (into.region, into.x, into.y) == ("bowl", -0.1, 1.6)

        bases = [q for (q,) in streams["inverse-kinematics"].fn("cube", cube, Grasp("top"))]
        assert bases
        checker = BaseChecker.of(scene)
        for q in bases:
            assert checker.free(q.pose)
            assert geometry.reaches(q, cube, Grasp("top"), 0.05)
            assert math.hypot(q.x - cube.x, q.y - cube.y) < 1.2
        far = BaseConf(-2.0, -2.0, 0.0)
        assert not geometry.reaches(far, cube, Grasp("top"), 0.05)

        views = [q for (q,) in itertools.islice(streams["sample-view"].fn("bowl"), 3)]
        assert views and all(checker.free(q.pose) for q in views)
        assert all(scene.tables["table2"].distance(q.x, q.y) < 0.8 for q in views)

        ((path,),) = [streams["plan-base-motion"].fn(BaseConf(0, 0, 0), views[0])]
        assert isinstance(path, BasePath)
        assert path.waypoints[-1][:2] == pytest.approx((views[0].x, views[0].y))


def test_static_facts_make_the_bowl_hold_one_cube() -> None:
    facts = static_facts(scenarios()["action-blocking-seen"].scene)
    assert Atom.of("Single", "bowl") in facts
    assert Atom.of("Stackable", "black_cube", "bowl") in facts
    assert Atom.of("Stackable", "bowl", "bowl") not in facts


# --------------------------------------------------------------------------- the world


def test_odometry_noise_is_corrected_by_fresh_detections() -> None:
    with open_scene() as scene:
        world = PyBulletWorld(scene, np.random.default_rng(5), snapshots=False)
        world.skills.config = type(world.skills.config)(odometry_noise=0.05, heading_noise=0.05)
        path = world.plan_drive(BaseConf(0.55, 0.1, 0.0))
        assert path is not None
        world.drive(path)
        believed, true = world.believed(), scene.base_pose()
        assert believed == pytest.approx((0.55, 0.1, 0.0))
        assert math.dist(believed[:2], true[:2]) > 1e-3  # the robot is not where it thinks
        seen = world.look("table1").find("cube")
        assert seen is not None
        # the detection is in the believed frame: mapped back it is where the cube truly is
        tx, ty = world.to_true(seen.pose.x, seen.pose.y)
        cube, _ = scene.pose("cube")
        assert math.hypot(tx - cube[0], ty - cube[1]) < 0.03


def test_seeded_events_stay_on_their_table_and_depend_on_the_seed() -> None:
    nominal = scenarios()["nominal"]
    spreads = {nominal.seeded_events(np.random.default_rng(s))[0] for s in range(20)}
    assert len(spreads) > 1
    rect = (0.5 - 0.12, 0.75 - 0.12)  # table1 is turned: 1.0 m in x, 1.5 m in y
    for e in spreads:
        assert e.table == "table1"
        assert abs(e.dx) <= rect[0] + 1e-9 and abs(e.dy) <= rect[1] + 1e-9


@pytest.mark.parametrize("axis", [(1.0, 0.0, -1.0), (0.0, 1.0, -0.3), (0.0, 0.0, -1.0)])
def test_look_orientation_points_the_gripper_along_the_axis(axis: tuple[float, ...]) -> None:
    import pybullet as p

    from llmpas.worlds.pybullet.pybullet_robot import look_orientation

    q = look_orientation(np.array(axis))
    m = np.array(p.getMatrixFromQuaternion(q)).reshape(3, 3)
    assert m[:, 2] == pytest.approx(np.array(axis) / np.linalg.norm(axis), abs=1e-6)
    assert np.linalg.det(m) == pytest.approx(1.0, abs=1e-6)
