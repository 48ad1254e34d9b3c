"""The planning scene of a standard robot at a site: the arm, its mount and the base's boxes from
a ``robot_description`` string (meshes it cannot read left out, and named), the site's places,
furniture and told objects, and the site's base poses among the planner's candidates."""

from __future__ import annotations

from collections.abc import Iterator
from itertools import islice

import numpy as np
import pytest

from llmpas.worlds.pybullet.kinematics import Collision
from llmpas.worlds.pybullet.pybullet_values import BaseConf
from llmpas.worlds.pybullet.scene import open_client
from llmpas.worlds.ros2.robot_model import DescriptionError, arm_model
from llmpas.worlds.ros2.site import parse
from llmpas.worlds.ros2.site_scene import SiteScene
from llmpas.worlds.ros2.site_session import SiteGeometry


@pytest.fixture(scope="module")
def description() -> str:
    from llmpas.worlds.pybullet_ros2.standard import robot_description

    return robot_description()  # what the simulated robot latches on robot_description


def test_the_arm_from_the_description(description: str) -> None:
    arm = arm_model(description, "panda_joint1", "base_link")
    assert arm.root == "panda_link0" and arm.mount == pytest.approx((0.2, 0.0, 0.405, 0.0))
    assert arm.joints[:7] == tuple(f"panda_joint{i}" for i in range(1, 8))
    assert len(arm.base) == 1 and arm.base[0].half[0] > 0.4  # the Husky's box
    assert arm.dropped == ()  # primitives only: nothing left out
    assert "package://" not in arm.urdf and "base_link" not in arm.urdf


def test_meshes_it_cannot_read_are_left_out_and_named(description: str) -> None:
    text = description.replace(
        '<box size="0.22565', '<mesh filename="package://franka_description/link0.stl" /><x a="'
    )
    arm = arm_model(text, "panda_joint1", "base_link")
    assert arm.dropped == ("panda_link0",)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("panda_joint1", "arm_joint1"), "no joint 'panda_joint1'"),
        (('name="base_to_panda" type="fixed"', 'name="base_to_panda" type="revolute"'),
         "between base_link and the arm is not fixed"),
        (('xyz="0.2 0 0.405" rpy="0 0 0"', 'xyz="0.2 0 0.405" rpy="0.3 0 0"'), "tilted"),
        (("<robot", "<robut"), "not URDF"),
    ],
)  # fmt: skip
def test_a_description_it_cannot_use_is_named(
    description: str, edit: tuple[str, str], message: str
) -> None:
    assert edit[0] in description
    with pytest.raises(DescriptionError, match=message):
        arm_model(description.replace(*edit), "panda_joint1", "base_link")


@pytest.fixture
def scene(description: str) -> Iterator[SiteScene]:
    raw = {
        "places": {"table1": {"box": {"center": [1.6, 0.0], "size": [1.0, 1.5],
                                      "height": 0.625}, "reach": [[0.5, 0.0, 0.0]],
                              "look": [[0.4, 0.3, 0.2]]}},
        "furniture": {"table1": {"size": [1.0, 1.5, 0.625], "pose": [1.6, 0.0, 0.3125, 0.0]}},
        "classes": {"cube": {"shape": "box", "size": [0.05, 0.05, 0.05]},
                    "lid": {"shape": "lid", "size": [0.2, 0.2, 0.05]}},
        "objects": {"cube": {"class": "cube", "place": "table1", "at": [1.3, 0.2]},
                    "spare": {"class": "cube"}},
    }  # fmt: skip
    site = parse(raw, "one-table.yaml")
    with open_client(False, data=False) as client:
        yield SiteScene(client, site, arm_model(description, "panda_joint1", "base_link"))


def test_the_planning_scene_of_a_site(scene: SiteScene) -> None:
    assert set(scene.tables) == {"table1"} and "furniture:table1" in scene.bodies
    at, _ = scene.pose("cube")
    assert at[0] == pytest.approx(1.3, abs=1e-3) and at[1] == pytest.approx(0.2, abs=1e-3)
    assert at[2] == pytest.approx(0.625 + 0.025, abs=5e-3)  # resting on the table's box
    assert scene.pose("spare")[0][2] < -1.0  # told of, whereabouts unknown: in no place
    static = [n for n in scene.bodies if n not in scene.movable()]
    assert not Collision(scene, static).collides(scene.arm_conf())  # home is free
    scene.set_base(0.3, 0.0, 0.0)
    hand, _ = scene.ee_pose()
    assert 0.3 < hand[0] < 1.0  # the arm moved with the base, mounted ahead of its centre


def test_the_sites_base_poses_are_among_the_planners(scene: SiteScene) -> None:
    geometry = SiteGeometry(scene, np.random.default_rng(0), scene.site)
    views = list(islice(geometry.views("table1", None), 40))
    assert BaseConf(0.4, 0.3, 0.2) in views and views[0] != BaseConf(0.4, 0.3, 0.2)


def test_an_object_seen_but_not_told_of_joins_the_scene(scene: SiteScene) -> None:
    """SiteSession.discover, on a real planning scene and belief: an object whose class id is
    one of the site's classes, lying on a place, joins the scene, the belief's static facts and
    the reasoner's vocabulary; anything else is ignored (and stays so)."""
    from llmpas.execution.context import Context
    from llmpas.language.logic import Atom
    from llmpas.worlds.ros2.site_session import SiteSession, site_belief

    session = object.__new__(SiteSession)  # the parts discover() reads, without a ROS graph
    session.site, session.scene = scene.site, scene
    belief = site_belief(scene, scene.site, BaseConf(0.0, 0.0, 0.0))
    session.context = Context(None, None, belief, np.random.default_rng(0))  # type: ignore[arg-type]
    session.ignored, session.discovered = set(), []
    assert not session.discover("mug", (1.5, 0.3, 0.65), (0.05, 0.05, 0.05))  # no such class
    assert not session.discover("mug", (1.5, 0.3, 0.65), (0.05,) * 3) and "mug" in session.ignored
    assert not session.discover("lid", (5.0, 5.0, 0.65), (0.2, 0.2, 0.05))  # on no place (yet)
    assert "lid" not in scene.movable() and Atom.of("Object", "lid") not in belief.facts
    assert session.discover("lid", (1.5, 0.3, 0.655), (0.2, 0.2, 0.05))
    assert "lid" in scene.movable() and scene.config.obj("lid").kind == "lid"
    assert scene.pose("lid")[0][0] == pytest.approx(1.5, abs=1e-3)
    assert Atom.of("Object", "lid") in belief.facts
    assert Atom.of("Stackable", "lid", "table1") in belief.facts
    assert "lid" in session.vocabulary.predicates["holding"][0]
    assert session.discovered == ["lid"] and "lid" in session.search.known
