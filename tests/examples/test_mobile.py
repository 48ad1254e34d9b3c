"""The kitchen example: geometry, the arm, the base planner, and plans that replay."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from llmpas.examples import mobile
from llmpas.examples.mobile import (
    ARM,
    BaseConf,
    Grasp,
    Kitchen,
    ObjPose,
    make_kitchen,
    make_problem,
)
from llmpas.examples.mobile.mobile_motion import RRTParams, drivable, traj_free
from llmpas.examples.mobile.mobile_streams import KinParams
from llmpas.examples.mobile.mobile_world import placement_area, supported
from llmpas.examples.mobile.robot import (
    JOINT_LIMITS,
    STEP,
    TUCKED,
    arm_free,
    fingertips,
    grasp_point,
)
from llmpas.language.problem import Problem

from .support import HandPlan


@pytest.fixture(scope="module")
def kitchen() -> Kitchen:
    return make_kitchen(3, 0)


def test_files_parse_with_the_expected_streams() -> None:
    p = make_problem(1, 0)
    assert [s.name for s in p.streams.streams] == list(mobile.STREAM_NAMES)
    assert {a.name for a in p.domain.actions} == {"move_base", "pick", "place", "clean", "cook"}
    assert {d.head.name for d in p.domain.derived} == {"on", "holding", "unsafepose"}


def test_defer_streams() -> None:
    p = make_problem(1, 0)
    deferred = {n for n, b in p.bound_streams.items() if b.info.deferred}
    assert deferred == {"plan-base-motion", "inverse-kinematics"}
    assert p.bound_streams["inverse-kinematics"].info.p_success < 1
    eager = make_problem(1, 0, defer_streams=())
    assert not any(b.info.deferred for b in eager.bound_streams.values())
    with pytest.raises(ValueError, match="unknown stream"):
        make_problem(1, 0, defer_streams=("teleport",))


@pytest.mark.parametrize(("n", "seed"), list(itertools.product((1, 2, 4, 7), (0, 1, 2))))
def test_kitchens_are_well_formed(n: int, seed: int) -> None:
    k = make_kitchen(n, seed)
    assert len(k.objects) == len(k.start) == len(k.goals) == n
    assert len(k.of_kind("sink")) == len(k.of_kind("stove")) == 1
    assert k.base_world().free(np.array([[k.home.x, k.home.y, k.home.theta]]))[0]
    for o, p, where in zip(k.objects, k.start, k.start_surface, strict=True):
        assert supported(k.surface(where), o, p)
    for (o1, p1), (o2, p2) in itertools.combinations(zip(k.objects, k.start, strict=True), 2):
        assert mobile.test_cfree_pose_pose(k, o1.name, p1, o2.name, p2)
    for g, where in zip(k.goals, k.start_surface, strict=True):
        if g.kind == "on":
            assert g.region != where and k.surface(g.region or "").kind == "table"
    assert make_kitchen(n, seed) == k


def test_all_goal_kinds_occur() -> None:
    kinds = {g.kind for seed in range(3) for g in make_kitchen(3, seed).goals}
    assert kinds == {"on", "cleaned", "cooked"}


def test_problem_grows_with_objects() -> None:
    sizes = [len(make_problem(n, 0).init) for n in (1, 2, 4, 8)]
    assert sizes == sorted(sizes) and len(set(sizes)) == 4


# ------------------------------------------------------------------------------ streams


def test_sample_pose_and_grasp(kitchen: Kitchen) -> None:
    rng = np.random.default_rng(0)
    o = kitchen.objects[0]
    for s in kitchen.surfaces:
        for (p,) in itertools.islice(mobile.sample_pose(kitchen, rng, o.name, s.name), 20):
            assert supported(s, o, p)
            assert placement_area(s, o).contains(p.x, p.y)
    assert list(mobile.sample_grasp(kitchen, o.name)) == [(Grasp("top"),), (Grasp("side"),)]


def test_cfree_is_symmetric(kitchen: Kitchen) -> None:
    rng = np.random.default_rng(2)
    a, b = kitchen.objects[0], kitchen.objects[1]
    gap = a.radius + b.radius + 0.01
    for _ in range(200):
        p1 = ObjPose(float(rng.uniform(0, 0.3)), 0.0, 0.75)
        p2 = ObjPose(float(rng.uniform(0, 0.3)), float(rng.uniform(0, 0.1)), 0.75)
        free = mobile.test_cfree_pose_pose(kitchen, a.name, p1, b.name, p2)
        assert free == mobile.test_cfree_pose_pose(kitchen, b.name, p2, a.name, p1)
        assert free == (np.hypot(p1.x - p2.x, p1.y - p2.y) >= gap)


def check_kin(
    k: Kitchen, obj: str, pose: ObjPose, grasp: Grasp, base: BaseConf, traj: mobile.ArmTraj
) -> None:
    assert traj.base == base and traj.arm == ARM
    q = np.array([[base.x, base.y, base.theta]])
    assert k.base_world().free(q)[0]
    path = np.array(traj.path)
    assert tuple(path[0]) == pytest.approx(TUCKED)
    assert np.abs(np.diff(path, axis=0)).max() <= STEP + 1e-9
    for j, (lo, hi) in enumerate(JOINT_LIMITS):
        assert lo - 1e-9 <= path[:, j].min() and path[:, j].max() <= hi + 1e-9
    assert arm_free(base, path, k.obstacles)
    target = grasp_point(k.obj(obj), pose, grasp)
    assert fingertips(base, traj.path[-1]) == pytest.approx(np.array(target), abs=1e-9)


def test_inverse_kinematics_reaches_every_surface(kitchen: Kitchen) -> None:
    rng = np.random.default_rng(3)
    o = kitchen.objects[0].name
    ok = total = 0
    for s in kitchen.surfaces:
        for (p,) in itertools.islice(mobile.sample_pose(kitchen, rng, o, s.name), 8):
            for g in (Grasp("top"), Grasp("side")):
                out = mobile.inverse_kinematics(kitchen, rng, KinParams(), ARM, o, p, g)
                total += 1
                if out is not None:
                    ok += 1
                    check_kin(kitchen, o, p, g, *out)
    assert ok / total >= 0.75


def test_inverse_kinematics_fails_sometimes_and_out_of_reach(kitchen: Kitchen) -> None:
    rng = np.random.default_rng(4)
    o = kitchen.objects[0].name
    p = kitchen.start[0]
    one_try = KinParams(attempts=1)
    fails = sum(
        mobile.inverse_kinematics(kitchen, rng, one_try, ARM, o, p, Grasp("top")) is None
        for _ in range(60)
    )
    assert 0 < fails < 40
    deep = ObjPose(1.0, kitchen.floor.y1 - 0.05, 0.9)  # at the back of the counter
    assert mobile.inverse_kinematics(kitchen, rng, KinParams(), ARM, o, deep, Grasp("top")) is None


def test_base_motion_is_collision_free(kitchen: Kitchen) -> None:
    rng = np.random.default_rng(5)
    params = RRTParams()
    o = kitchen.objects[0].name
    goals = []
    for s in (kitchen.of_kind("stove")[0], kitchen.surfaces[1]):
        (p,) = next(mobile.sample_pose(kitchen, rng, o, s.name))
        out = None
        while out is None:
            out = mobile.inverse_kinematics(kitchen, rng, KinParams(), ARM, o, p, Grasp("top"))
        goals.append(out[0])
    for q2 in goals:
        res = mobile.plan_base_motion(kitchen, rng, params, kitchen.home, q2)
        assert res is not None
        (t,) = res
        assert t.path[0] == kitchen.home and t.path[-1] == q2
        assert traj_free(t, kitchen.base_world(), params)
        assert drivable(t)
        assert t.length >= np.hypot(q2.x - kitchen.home.x, q2.y - kitchen.home.y) - 1e-9


def test_base_motion_into_a_table_fails(kitchen: Kitchen) -> None:
    cx, cy = kitchen.obstacles[0].rect.center
    blocked = BaseConf(cx, cy, 0.0)
    rng = np.random.default_rng(6)
    assert mobile.plan_base_motion(kitchen, rng, RRTParams(), kitchen.home, blocked) is None


# ------------------------------------------------------------------------------ hand plans


class Robot:
    """Builds a plan by calling the problem's streams, one object at a time."""

    def __init__(self, problem: Problem, kitchen: Kitchen) -> None:
        self.hp = HandPlan(problem)
        self.k = kitchen
        self.conf = kitchen.home
        self.poses = {o.name: p for o, p in zip(kitchen.objects, kitchen.start, strict=True)}

    def kin(self, obj: str, pose: ObjPose, grasp: Grasp) -> tuple[BaseConf, mobile.ArmTraj]:
        for _ in range(10):
            out = self.hp.call("inverse-kinematics", ARM, obj, pose, grasp)
            if out is not None:
                return out[0], out[1]
        raise AssertionError(f"no IK for {obj} at {pose}")

    def drive(self, q: BaseConf) -> None:
        for _ in range(5):
            out = self.hp.call("plan-base-motion", self.conf, q)
            if out is not None:
                self.hp.step("move_base", self.conf, q, out[0])
                self.conf = q
                return
        raise AssertionError("no base motion")

    def transfer(self, obj: str, region: str) -> None:
        out = self.hp.call("sample-grasp", obj)
        assert out is not None
        g = out[0]
        q, t = self.kin(obj, self.poses[obj], g)
        self.drive(q)
        self.hp.step("pick", ARM, obj, self.poses[obj], g, q, t)
        pose = self.free_pose(obj, region)
        q, t = self.kin(obj, pose, g)
        self.drive(q)
        self.hp.step("place", ARM, obj, pose, g, q, t)
        self.poses[obj] = pose

    def free_pose(self, obj: str, region: str) -> ObjPose:
        samples = self.hp.problem.bound_streams["sample-pose"].outputs((obj, region))
        for (p,) in itertools.islice(samples, 1000):
            if all(
                mobile.test_cfree_pose_pose(self.k, obj, p, other, q)
                for other, q in self.poses.items()
            ):
                self.hp.certify("sample-pose", (obj, region), (p,))
                return p
        raise AssertionError(f"no room for {obj} on {region}")

    def achieve(self, goal: mobile.Goal) -> None:
        sink, stove = self.k.of_kind("sink")[0].name, self.k.of_kind("stove")[0].name
        if goal.kind == "on":
            self.transfer(goal.obj, goal.region or "")
            return
        self.transfer(goal.obj, sink)
        self.hp.step("clean", goal.obj, sink)
        if goal.kind == "cooked":
            self.transfer(goal.obj, stove)
            self.hp.step("cook", goal.obj, stove)


@pytest.mark.parametrize(("n", "seed"), [(1, 0), (1, 1), (1, 2), (2, 0)])
def test_hand_plan_replays(n: int, seed: int) -> None:
    p, k = make_problem(n, seed), make_kitchen(n, seed)
    robot = Robot(p, k)
    assert not robot.hp.replay().valid  # the goal does not hold initially
    for g in k.goals:
        robot.achieve(g)
    robot.hp.run_tests("test-cfree-pose-pose")
    r = robot.hp.replay()
    assert r.valid, r.message
