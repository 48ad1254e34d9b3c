"""Robot profiles: the shipped ones load, names resolve, a bad file is one line naming the key."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.worlds.ros2.profile import ProfileError, RobotProfile, load, shipped


def test_the_shipped_profiles_load() -> None:
    found = shipped()
    assert {"pybullet", "pybullet-standard"} <= set(found)
    plain, standard = load("pybullet"), load("pybullet-standard")
    assert plain == RobotProfile(source=plain.source)  # the file says what the defaults are
    assert standard.standard and not plain.standard
    assert standard.topics.detections.qos.reliability == "best_effort"
    assert standard.look("arm").detections == "wrist_detections"


def write(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "robot.yaml"
    f.write_text(text)
    return f


def test_a_namespaced_profile_with_places(tmp_path: Path) -> None:
    f = write(
        tmp_path,
        "namespace: /robot1\ninterfaces: standard\n"
        "topics: {odom: {name: odometry/filtered, qos: {reliability: best_effort}}}\n"
        "places: [{name: shelf, footprint: [[0, 0], [1, 0], [1, 2], [0, 2]]}]\n"
        "furniture: [{name: shelf, size: [1, 2, 0.8], pose: [0.5, 1, 0.4, 0]}]\n",
    )
    p = load(f)
    assert p.namespace == "/robot1" and p.topics.odom.name == "odometry/filtered"
    assert p.topics.odom.qos.reliability == "best_effort"
    assert p.topics.odom.qos.durability == "volatile"
    assert p.place_of(0.5, 1.5) == "shelf" and p.place_of(1.5, 1.0) is None


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("interfaces: ros1\n", "interfaces: one of"),
        ("namespace: robot1\n", "namespace: absolute"),
        ("topics: {odom: {name: odom, qos: {reliability: sometimes}}}\n",
         "topics.odom.qos.reliability: one of"),
        ("topics: {odom: {nme: odom}}\n", "topics.odom.nme: unknown key"),
        ("arm: {joints: [a, b], home: [0]}\n", "arm.home: 2 positions"),
        ("places: [{name: t, footprint: [[0, 0], [1, 1]]}]\n", "places[0].footprint: at least"),
        ("furniture: [{name: t, size: [1, 1]}]\n", "furniture[0].size: 3 numbers"),
        ("looks: [{camera: nose}]\n", "looks[0].camera: one of"),
        ("rmw: cyclone\n", "rmw: an RMW implementation"),
        ("use_sim_time: yes please\n", "use_sim_time: true or false"),
        ("frames: {map: [1]}\n", "frames.map: a single value"),
        ("a: [\n", "line"),
        ("- 1\n", "the profile: a mapping"),
    ],
)  # fmt: skip
def test_a_bad_profile_names_the_file_and_the_key(tmp_path: Path, text: str, where: str) -> None:
    f = write(tmp_path, text)
    with pytest.raises(ProfileError) as e:
        load(f)
    line = str(e.value)
    assert line.startswith(f"{f}: ") and where in line and "\n" not in line


def test_a_missing_profile(tmp_path: Path) -> None:
    with pytest.raises(ProfileError, match="cannot read the robot profile"):
        load(tmp_path / "nope.yaml")


SIM_TIME = """
import sys
from pathlib import Path
from llmpas.worlds.ros2.env import RosEnv
from llmpas.worlds.ros2.process import ros_context
from llmpas.worlds.ros2.profile import load
from llmpas.worlds.ros2.standard_robot import StandardRobot

profile = load(sys.argv[1])
with ros_context(RosEnv(int(sys.argv[2]), Path(sys.argv[3]))) as context:
    robot = StandardRobot(context, None, profile, None, build_scene=lambda d, b: None)
    try:
        clock = robot.node.get_clock()
        print(robot.node.get_parameter("use_sim_time").value, clock.clock_type.name)
    finally:
        robot.shutdown()
"""


def test_use_sim_time_gives_the_client_the_robots_clock(tmp_path: Path) -> None:
    """``use_sim_time: true``: the standard client's node follows /clock (its ROS_TIME clock
    with use_sim_time set), as the stamps it compares come from a simulated clock; not so by
    default."""
    import subprocess
    import sys

    from llmpas.worlds.ros2.env import random_domain
    from tests.worlds.ros2.conftest import REPO, ros_environ

    f = write(tmp_path, "interfaces: standard\nuse_sim_time: true\n")
    assert load(f).use_sim_time and not load("pybullet-standard").use_sim_time
    for profile, expected in ((str(f), "True"), ("pybullet-standard", "False")):
        domain = random_domain()
        out = subprocess.run(
            [sys.executable, "-c", SIM_TIME, profile, str(domain), str(tmp_path / "log")],
            env=ros_environ(domain, tmp_path / "log"), capture_output=True, text=True,
            timeout=120, cwd=REPO,
        )  # fmt: skip
        assert out.returncode == 0, out.stderr[-2000:]
        assert out.stdout.split()[-2:] == [expected, "ROS_TIME"], out.stdout
