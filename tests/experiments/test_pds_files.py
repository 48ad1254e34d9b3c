"""The problems and streams for PDDLStream's 2-D files (the files themselves are not shipped:
the planning run is measured by ``bench tamp --pddlstream-files``, see docs/results/tamp.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.experiments import pds_files
from llmpas.experiments.pds_files import (
    BLOCK_WIDTH,
    cfree,
    contained,
    distance,
    ik,
    init_and_goal,
    make_instance,
    motion,
)


def test_mirror_is_pddlstreams_mirror_and_does_not_depend_on_the_seed() -> None:
    m = make_instance("mirror", 3, 0)
    assert m.start == (-2.0, -5.0, -8.0) and m.goals == (2.0, 5.0, 8.0)
    assert dict(m.robots) == {"r0": (-5.0, 6.0), "r1": (5.0, 6.0)}
    assert make_instance("mirror", 3, 7) == m


@pytest.mark.parametrize("n", [2, 3, 5, 8])
def test_packed_starts_every_block_in_another_slot(n: int) -> None:
    p = make_instance("packed", n, 1)
    slots = [p.regions[g] for g in p.goals if isinstance(g, str)]
    assert len(slots) == n
    for lo, hi in slots:
        assert BLOCK_WIDTH < hi - lo < 2 * BLOCK_WIDTH
    for i, x in enumerate(p.start):
        inside = [k for k, s in enumerate(slots) if contained(s, (x, 0.0))]
        assert len(inside) == 1 and inside[0] != i  # in one slot, not its own
    assert make_instance("packed", n, 1) == p and make_instance("packed", n, 2) != p


def test_streams_follow_the_stated_geometry() -> None:
    assert ik((3.0, 0.0), (0.0, -2.5)) == (3.0, 5.0)
    assert motion((-5.0, 6.0), (3.0, 5.0)) == ((-5.0, 6.0), (-5.0, 5.0), (3.0, 5.0), (3.0, 5.0))
    assert distance((-5.0, 6.0), (-2.0, 5.0)) == 14.0  # 10 + |dx| + |dy|
    assert cfree("A", (0.0, 0.0), "B", (2.5, 0.0)) and not cfree("A", (0.0, 0.0), "B", (2.0, 0.0))
    assert cfree("A", (0.0, 0.0), "A", (0.0, 0.0))  # a block never collides with itself


def test_goals_are_stated_as_in_pddlstreams_example() -> None:
    init, goal = init_and_goal(make_instance("packed", 2, 0))
    assert ("In", "A", "s1") in goal and ("AtConf", "r0", (-5.0, 6.0)) in goal
    assert ("Placeable", "A", "grey") in init and ("Region", "s1") in init
    _, mirror_goal = init_and_goal(make_instance("mirror", 1, 0))
    assert ("AtPose", "A", (2.0, 0.0)) in mirror_goal


def test_a_folder_without_the_files_is_named(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=str(tmp_path)):
        pds_files.check_files(tmp_path)
    with pytest.raises(ValueError, match="unknown family"):
        make_instance("spiral", 2, 0)
