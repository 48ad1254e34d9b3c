"""The PyBullet robot as a standard ROS 2 robot (``llmpas robot pybullet SCENARIO --standard``):
what its graph holds, a namespaced robot driven through a profile (its publishers VOLATILE and
best effort), and the loop against it. Real graphs, each on a random domain, on localhost."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from llmpas.worlds.ros2.env import random_domain
from tests.worlds.ros2.conftest import REPO, llmpas, ros_environ

CASSETTE = "replay:tests/data/cassettes/qwen1.5b-pybullet-hidden"

# a namespaced standard robot whose joint states and odometry are VOLATILE and best effort
PROFILE = """
name: robot1
interfaces: standard
namespace: /robot1
topics:
  odom: {name: odometry/filtered, qos: {reliability: best_effort, durability: volatile}}
  joint_states: {name: joint_states, qos: {reliability: best_effort, durability: volatile}}
  detections: {name: camera/detections, qos: {reliability: best_effort}}
  wrist_detections: {name: wrist/detections, qos: {reliability: best_effort}}
  tf: {name: tf, qos: {reliability: reliable, durability: volatile, depth: 100}}
  tf_static: {name: tf_static, qos: {reliability: reliable, durability: transient_local}}
places:
  - {name: shelf, frame: odom, footprint: [[-3.5, -3.2], [-2.5, -3.2], [-2.5, -2.8], [-3.5, -2.8]]}
furniture:
  - {name: shelf, frame: odom, size: [1.0, 0.4, 1.6], pose: [-3.0, -3.0, 0.8, 0.0]}
"""

GRAPH = """
import json, sys, time
from pathlib import Path
import rclpy
from rclpy.action import get_action_names_and_types
from llmpas.worlds.ros2.env import from_environment
from llmpas.worlds.ros2.ros2_session import ros_context

with ros_context(from_environment(Path(sys.argv[1]))) as context:
    node = rclpy.create_node("graph_probe", context=context)
    want = sys.argv[2:]
    end = time.monotonic() + 90
    while time.monotonic() < end:
        topics = dict(node.get_topic_names_and_types())
        if all(w in topics for w in want):
            break
        time.sleep(0.2)
    time.sleep(1.0)
    out = {
        "topics": {k: v for k, v in node.get_topic_names_and_types()},
        "services": {k: v for k, v in node.get_service_names_and_types()},
        "actions": {k: v for k, v in get_action_names_and_types(node)},
    }
    node.destroy_node()
print(json.dumps(out))
"""

CLIENT = """
import json, sys
from pathlib import Path
import numpy as np
from llmpas.worlds.pybullet.pybullet_scenarios import resolve, setup_scene
from llmpas.worlds.pybullet.scene import Scene, open_client
from llmpas.worlds.pybullet.pybullet_values import BaseConf
from llmpas.worlds.ros2.client import Timeouts
from llmpas.worlds.ros2.env import from_environment
from llmpas.worlds.ros2.profile import load
from llmpas.worlds.ros2.ros2_session import ros_context
from llmpas.worlds.ros2.standard_robot import StandardRobot
from llmpas.execution.robot_protocols import finish

out = {}
profile = load(sys.argv[2])
with ros_context(from_environment(Path(sys.argv[1]))) as context, open_client(False) as c:
    scene = Scene(c, resolve("object-loss").scene)
    setup_scene(scene, resolve("object-loss"))
    robot = StandardRobot(context, scene, profile, np.random.default_rng(0), Timeouts(discover=90))
    robot.wait_for_servers()
    out["names"] = sorted(robot.names.values())
    out["start"] = list(robot.believed)
    out["places"] = [[p.name, p.frame, [list(v) for v in p.footprint]] for p in robot.places]
    out["furniture"] = list(robot.scene.pose("shelf")[0])
    look = robot.look()
    out["look"] = [[d.obj, d.region, d.pose.x, d.pose.y, d.pose.z] for d in look.detections]
    out["viewed"] = list(look.viewed)
    x, y, t = robot.believed
    handle = robot.move_base(BaseConf(x + 0.3, y, t))  # a handle: the goal runs while polled
    out["first_poll"] = handle.poll().status.value
    drive = finish(handle)
    out["drive"] = [drive.ok, drive.message, list(robot.believed)]
    far = finish(robot.move_base(BaseConf(1.6, 0.0, 0.0)))  # inside table1: no path
    out["blocked"] = [far.ok, far.data.get("reason"), far.data.get("error_code")]
    home = finish(robot.move_arm("home"))
    out["home"] = [home.ok, home.message, list(robot.scene.arm_conf())]
    robot.shutdown()
print(json.dumps(out))
"""


def _probe(script: str, domain: int, tmp_path: Path, *args: str) -> dict:
    proc = subprocess.run(
        [sys.executable, "-c", script, str(tmp_path / "probe-log"), *args],
        env=ros_environ(domain, tmp_path / "probe-log"),
        capture_output=True,
        text=True,
        timeout=300,
        cwd=REPO,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_standard_robot_serves_no_llmpas_interface(tmp_path: Path, start_robot) -> None:
    domain = random_domain()
    start_robot(domain, "--standard")
    graph = _probe(
        GRAPH, domain, tmp_path, "/tf", "/tf_static", "/joint_states", "/detections",
        "/robot_description", "/odom",
    )  # fmt: skip
    every = [t for kinds in graph.values() for types in kinds.values() for t in types]
    assert not [t for t in every if "llmpas" in t], every
    topics, actions = graph["topics"], graph["actions"]
    assert topics["/tf"] == ["tf2_msgs/msg/TFMessage"]
    assert topics["/tf_static"] == ["tf2_msgs/msg/TFMessage"]
    assert topics["/detections"] == ["vision_msgs/msg/Detection3DArray"]
    assert topics["/joint_states"] == ["sensor_msgs/msg/JointState"]
    assert topics["/robot_description"] == ["std_msgs/msg/String"]
    assert actions["/navigate_to_pose"] == ["nav2_msgs/action/NavigateToPose"]
    assert actions["/arm_controller/follow_joint_trajectory"] == [
        "control_msgs/action/FollowJointTrajectory"
    ]
    assert actions["/gripper_controller/gripper_cmd"] == ["control_msgs/action/GripperCommand"]
    assert set(actions) == {
        "/navigate_to_pose",
        "/arm_controller/follow_joint_trajectory",
        "/gripper_controller/gripper_cmd",
    }


def test_a_namespaced_standard_robot_driven_through_a_profile(tmp_path: Path, start_robot) -> None:
    """/robot1/...: Nav2 goals, TF for the base pose, a detector's Detection3DArray in the
    mast camera's frame resolved through TF, an unreachable goal's Nav2 error code as the
    failure's reason, and a trajectory llmpas planned."""
    profile = tmp_path / "robot1.yaml"
    profile.write_text(PROFILE)
    domain = random_domain()
    start_robot(domain, "--robot-profile", str(profile))
    out = _probe(CLIENT, domain, tmp_path, str(profile))
    assert out["names"] == [
        "/robot1/arm_controller/follow_joint_trajectory",
        "/robot1/gripper_controller/gripper_cmd",
        "/robot1/navigate_to_pose",
    ]
    assert out["start"] == [0.0, 0.0, 0.0]
    # the profile's static geometry, from its frame (odom) into map, in the planning scene
    assert out["places"][0][:2] == ["shelf", "map"] and len(out["places"][0][2]) == 4
    assert [round(v, 6) for v in out["furniture"]] == [-3.0, -3.0, 0.8]
    # the robot starts facing table1, the cube on it: seen there, in map
    from llmpas.worlds.pybullet.pybullet_scenarios import resolve

    config = resolve("object-loss").scene
    cube = config.obj("cube")
    table = config.table(cube.table)
    seen = {name: (region, x, y, z) for name, region, x, y, z in out["look"]}
    assert cube.table in out["viewed"]
    region, x, y, z = seen["cube"]
    assert region == cube.table
    assert abs(x - (table.x + cube.dx)) < 0.05 and abs(y - (table.y + cube.dy)) < 0.05
    assert 0.6 < z < 0.7
    assert out["first_poll"] == "running"
    ok, _, believed = out["drive"]
    assert ok and abs(believed[0] - 0.3) < 1e-6  # TF's map -> base_link after the goal
    assert out["blocked"] == [False, "blocked", 208]  # Nav2's NO_VALID_PATH
    ok, _, q = out["home"]
    assert ok and abs(q[3] + 3.0) < 0.05


def test_volatile_best_effort_publishers_reach_the_recording(tmp_path: Path) -> None:
    """The run starts the namespaced robot itself with the profile (its odometry on
    odometry/filtered, joint states and odometry best effort and VOLATILE, as
    diff_drive_controller and joint_state_broadcaster may publish); the MCAP holds them."""
    profile = tmp_path / "robot1.yaml"
    profile.write_text(PROFILE)
    domain = random_domain()
    run = llmpas(
        ["run", "object-loss", "--world", "ros2", "--robot-profile", str(profile), "--no-llm",
         "--out", str(tmp_path / "run")],
        domain,
        tmp_path / "log",
    )  # fmt: skip
    _, err = run.communicate(timeout=900)
    assert run.returncode in (0, 1), err[-3000:]
    about = json.loads((tmp_path / "run" / "ros.json").read_text())
    channels = about["channels"]
    assert channels["/robot1/odometry/filtered"]["messages"] > 0
    assert channels["/robot1/joint_states"]["messages"] > 0
    assert channels["/robot1/navigate_to_pose/goal"]["messages"] > 0
    assert channels["/robot1/camera/detections"]["type"] == "vision_msgs/msg/Detection3DArray"
    assert about["profile"]["namespace"] == "/robot1"
    assert not [c for c in channels if "llmpas" in c]


def test_replayed_model_against_the_standard_robot(tmp_path: Path) -> None:
    """The must-show run against ``llmpas robot pybullet object-loss --standard`` (started by
    the same command): "task done" with the in-process run's rounds and goals."""
    domain = random_domain()
    ros = llmpas(
        ["run", "object-loss", "--world", "ros2", "--robot-profile", "pybullet-standard",
         "--llm", CASSETTE, "--out", str(tmp_path / "ros")],
        domain,
        tmp_path / "ros-log",
    )  # fmt: skip
    local = llmpas(
        ["run", "object-loss", "--llm", CASSETTE, "--out", str(tmp_path / "local")],
        domain,
        tmp_path / "local-log",
    )
    out, err = ros.communicate(timeout=900)
    _, local_err = local.communicate(timeout=900)
    assert ros.returncode == 0, err[-3000:]
    assert local.returncode == 0, local_err[-2000:]
    assert out.strip().splitlines()[-1].startswith("task done")

    def rounds(folder: Path) -> list[tuple[str, str]]:
        loop = json.loads((folder / "loop.json").read_text())
        return [(r["goal"], r["status"]) for r in loop["rounds"]]

    assert rounds(tmp_path / "ros") == rounds(tmp_path / "local")
    about = json.loads((tmp_path / "ros" / "ros.json").read_text())
    assert about["profile"]["interfaces"] == "standard"
    assert not [c for c in about["channels"] if "llmpas" in c]
