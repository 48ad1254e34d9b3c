"""The 2-D TAMP example: geometry, streams, and hand-made plans that replay to the goal."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from llmpas.examples import tamp2d
from llmpas.examples.tamp2d import (
    BlockSpec,
    Conf,
    Interval,
    Pose,
    Scene,
    make_problem,
    make_world,
    overlap,
)
from llmpas.examples.tamp2d.tamp2d_world import GRIP_OFFSET
from llmpas.language.logic import Atom, atoms_of
from llmpas.language.problem import Problem

from .support import HandPlan

SIZES = (1, 2, 3, 5, 8)
SEEDS = (0, 1, 2, 3, 4)


def test_files_parse_with_the_expected_streams() -> None:
    p = make_problem(1, 0)
    assert [s.name for s in p.streams.streams] == list(tamp2d.STREAM_NAMES)
    assert [f.name for f in p.streams.functions] == ["dist"]
    assert {d.head.name for d in p.domain.derived} == {"in", "unsafe"}
    assert p.streams.stream("test-cfree").is_test


@pytest.mark.parametrize(("n", "seed"), list(itertools.product(SIZES, SEEDS)))
def test_worlds_are_feasible(n: int, seed: int) -> None:
    w = make_world(n, seed)
    assert len(w.blocks) == len(w.regions) == len(w.start) == n
    for b, r, p in zip(w.blocks, w.regions, w.start, strict=True):
        assert r.width >= 1.3 * b.width  # room for the block in its goal region
        assert w.table.contains(b, p)
        assert not r.contains(b, p)  # the goal is not already achieved
    for (b1, p1), (b2, p2) in itertools.combinations(zip(w.blocks, w.start, strict=True), 2):
        assert not overlap(b1, p1, b2, p2)
    for r1, r2 in itertools.combinations(w.regions, 2):
        assert r1.hi < r2.lo or r2.hi < r1.lo
    assert make_world(n, seed) == w


def test_blocks_often_start_in_other_goal_regions() -> None:
    blocked = 0
    for seed in range(20):
        w = make_world(4, seed)
        blocked += sum(
            r.contains(b, p)
            for b, p in zip(w.blocks, w.start, strict=True)
            for r in w.regions
            if r is not w.goal_of(b.name)
        )
    assert blocked >= 10


def test_problem_grows_with_blocks() -> None:
    sizes = [len(make_problem(n, 0).init) for n in (1, 2, 4, 8)]
    assert sizes == sorted(sizes) and len(set(sizes)) == 4
    p = make_problem(3, 0)
    goal_preds = sorted(a.predicate for a in atoms_of(p.goal))
    assert goal_preds == ["atconf", "in", "in", "in"]


def test_defer_streams() -> None:
    p = make_problem(1, 0, defer_streams=("plan-motion",))
    assert p.bound_streams["plan-motion"].info.deferred
    assert not p.bound_streams["sample-pose"].info.deferred
    with pytest.raises(ValueError, match="unknown stream"):
        make_problem(1, 0, defer_streams=("teleport",))


# ------------------------------------------------------------------------------ streams


@pytest.fixture
def world() -> Scene:
    return make_world(3, 0)


def test_sample_pose_stays_in_region(world: Scene) -> None:
    rng = np.random.default_rng(0)
    for b, r in itertools.product(world.blocks, (*world.regions, world.table)):
        poses = [p for (p,) in itertools.islice(tamp2d.sample_pose(world, rng, b.name, r.name), 30)]
        assert len(set(poses)) == 30
        assert all(r.contains(b, p) for p in poses)


def test_sample_pose_in_a_region_too_narrow_is_empty() -> None:
    narrow = Interval("r1", 1.0, 1.5)
    w = Scene(
        (BlockSpec("b1", 1.0, 0.5),), (narrow,), Interval("table", 0, 5), (Pose(3),), Conf(0, 2), 2
    )
    assert list(tamp2d.sample_pose(w, np.random.default_rng(0), "b1", "r1")) == []


def test_inverse_kinematics(world: Scene) -> None:
    b = world.blocks[0]
    out = tamp2d.inverse_kinematics(world, b.name, Pose(2.0))
    assert out == (Conf(2.0, b.height + GRIP_OFFSET),)
    assert tamp2d.inverse_kinematics(world, b.name, Pose(world.table.hi + 1)) is None


def test_plan_motion(world: Scene) -> None:
    q1, q2 = Conf(1.0, 0.7), Conf(5.0, 0.9)
    out = tamp2d.plan_motion(world, q1, q2)
    assert out is not None
    (t,) = out
    assert t.waypoints[0] == q1 and t.waypoints[-1] == q2
    assert t.length == pytest.approx(tamp2d.distance(world, q1, q2))
    # travelling at height: a held block hanging below the gripper clears every standing block
    hang = max(b.height for b in world.blocks) + GRIP_OFFSET
    for a, c in itertools.pairwise(t.waypoints):
        if a.x != c.x:
            assert a.y == c.y == world.travel_height
            assert world.travel_height - hang > max(b.height for b in world.blocks)
    assert tamp2d.plan_motion(world, q1, Conf(world.table.hi + 1, 1.0)) is None
    assert tamp2d.plan_motion(world, world.home, world.home) == (tamp2d.Traj((world.home,)),)


def test_cfree_is_symmetric_and_exact(world: Scene) -> None:
    rng = np.random.default_rng(1)
    b1, b2 = world.blocks[0].name, world.blocks[1].name
    spec1, spec2 = world.block(b1), world.block(b2)
    for _ in range(200):
        p1, p2 = Pose(float(rng.uniform(0, 4))), Pose(float(rng.uniform(0, 4)))
        free = tamp2d.test_cfree(world, b1, p1, b2, p2)
        assert free == tamp2d.test_cfree(world, b2, p2, b1, p1)
        lo1, hi1 = spec1.footprint(p1)
        lo2, hi2 = spec2.footprint(p2)
        assert free == (hi1 <= lo2 + 1e-6 or hi2 <= lo1 + 1e-6)
    touching = Pose(1.0 + (spec1.width + spec2.width) / 2)
    assert tamp2d.test_cfree(world, b1, Pose(1.0), b2, touching)
    assert tamp2d.test_cfree(world, b1, Pose(1.0), b1, Pose(1.0))


# ------------------------------------------------------------------------------ hand plans


class Mover:
    """Builds a plan by calling the problem's streams: transfer blocks one by one."""

    def __init__(self, problem: Problem, world: Scene) -> None:
        self.hp = HandPlan(problem)
        self.world = world
        self.conf = world.home
        self.poses = {b.name: p for b, p in zip(world.blocks, world.start, strict=True)}

    def go(self, q: Conf) -> None:
        out = self.hp.call("plan-motion", self.conf, q)
        assert out is not None
        self.hp.step("move", self.conf, out[0], q)
        self.conf = q

    def transfer(self, block: str, region: str, outside: tuple[Interval, ...] = ()) -> None:
        spec = self.world.block(block)
        here = self.hp.call("inverse-kinematics", block, self.poses[block])
        assert here is not None
        self.go(here[0])
        self.hp.step("pick", block, self.poses[block], here[0])
        pose = self.free_pose(block, region, outside)
        self.hp.certify("sample-pose", (block, region), (pose,))
        there = self.hp.call("inverse-kinematics", block, pose)
        assert there is not None
        self.go(there[0])
        self.hp.step("place", block, pose, there[0])
        self.poses[block] = pose
        assert self.world.region(region).contains(spec, pose)

    def free_pose(self, block: str, region: str, outside: tuple[Interval, ...]) -> Pose:
        spec = self.world.block(block)
        samples = self.hp.problem.bound_streams["sample-pose"].outputs((block, region))
        for (p,) in itertools.islice(samples, 5000):
            clear = all(
                self.hp.problem.bound_streams["test-cfree"].impl.fn(block, p, other, q)
                for other, q in self.poses.items()
                if other != block
            )
            if clear and not any(_touches(spec, p, r) for r in outside):
                return p
        raise AssertionError(f"no free pose for {block} in {region}")

    def finish(self) -> None:
        self.go(self.world.home)
        self.hp.run_tests("test-cfree")


def _touches(b: BlockSpec, p: Pose, r: Interval) -> bool:
    lo, hi = b.footprint(p)
    return lo < r.hi and r.lo < hi


def test_hand_plan_for_one_block_replays() -> None:
    p = make_problem(1, 0)
    w = make_world(1, 0)
    m = Mover(p, w)
    m.transfer("b1", "r1")
    m.finish()
    assert [s[0] for s in m.hp.steps] == ["move", "pick", "move", "place", "move"]
    r = m.hp.replay()
    assert r.valid, r.message
    assert r.cost > 2.0  # two unit-cost manipulations plus the distances driven


@pytest.mark.parametrize(("n", "seed"), [(2, 0), (3, 1), (4, 2), (5, 3)])
def test_two_phase_plan_replays(n: int, seed: int) -> None:
    """Clear every goal region onto free table space, then fill each goal region: always
    possible in generated worlds (the gaps between regions fit any block)."""
    p, w = make_problem(n, seed), make_world(n, seed)
    m = Mover(p, w)
    for b in w.blocks:
        if any(_touches(b, m.poses[b.name], r) for r in w.regions):
            m.transfer(b.name, "table", outside=w.regions)
    for b, region in zip(w.blocks, w.regions, strict=True):
        m.transfer(b.name, region.name)
    m.finish()
    result = m.hp.replay()
    assert result.valid, result.message


def test_placing_onto_another_block_is_refused() -> None:
    """The derived Unsafe with its negated test atom: a rejected pair blocks the place."""
    p, w = make_problem(2, 0), make_world(2, 0)
    m = Mover(p, w)
    b1, b2 = w.blocks
    here = m.hp.call("inverse-kinematics", b1.name, m.poses[b1.name])
    assert here is not None
    m.go(here[0])
    m.hp.step("pick", b1.name, m.poses[b1.name], here[0])
    onto = m.poses[b2.name]  # right on top of b2's footprint
    m.hp.certify("sample-pose", (b1.name, "table"), (onto,))
    there = m.hp.call("inverse-kinematics", b1.name, onto)
    assert there is not None
    m.go(there[0])
    m.hp.step("place", b1.name, onto, there[0])
    m.hp.run_tests("test-cfree")
    cfree = Atom("cfree", (b1.name, m.hp.name(onto), b2.name, m.hp.name(onto)))
    assert cfree not in m.hp.facts
    r = m.hp.replay()
    assert not r.valid and r.failed_step == 3
