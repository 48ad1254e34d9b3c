"""The standard interfaces over a real graph, goal by goal: a client process drives the robot
node's FollowJointTrajectory and NavigateToPose servers through :class:`RosRobot` (the loop's
``move_arm("home")`` and ``move_base``), an abort of a standard server is a skill failure, and
the GripperCommand server closes and opens the fingers."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from llmpas.worlds.ros2.env import random_domain
from tests.worlds.ros2.conftest import REPO, ros_environ

CLIENT = """
import json, sys
from pathlib import Path
from llmpas.execution.robot_protocols import finish
from llmpas.worlds.pybullet.pybullet_scenarios import resolve
from llmpas.worlds.pybullet.scene import Scene, open_client
from llmpas.worlds.pybullet.pybullet_values import BaseConf
from llmpas.worlds.ros2.client import RosRobot, Timeouts
from llmpas.worlds.ros2.env import from_environment
from llmpas.worlds.ros2.ros2_session import ros_context

out = {}
with ros_context(from_environment(Path(sys.argv[1]))) as context, open_client(False) as c:
    robot = RosRobot(context, Scene(c, resolve("object-loss").scene), Timeouts(discover=60))
    robot.wait_for_servers()
    home = finish(robot.move_arm("home"))  # a handle: polled to its end
    out["home"] = [home.ok, home.message]
    out["joints"] = list(robot.scene.arm_conf())
    x, y, t = robot.believed
    drive = finish(robot.move_base(BaseConf(x + 0.3, y, t)))
    out["drive"] = [drive.ok, drive.message, list(robot.believed)]
    goal = robot.types["arm_controller/follow_joint_trajectory"].Goal()
    goal.trajectory.joint_names = ["elbow"]
    failed, result = robot.goal("arm_controller/follow_joint_trajectory", goal)
    out["bad_joints"] = [failed.message, failed.data.get("reason"), result.error_code]
    grip = robot.types["gripper_controller/gripper_cmd"].Goal()
    grip.command.position, grip.command.max_effort = 0.0, 40.0
    failed, result = robot.goal("gripper_controller/gripper_cmd", grip)
    out["close"] = [failed is None, result.position, result.stalled, result.reached_goal]
    grip.command.position = 0.04
    failed, result = robot.goal("gripper_controller/gripper_cmd", grip)
    out["open"] = [failed is None, result.position, result.stalled]
    robot.shutdown()
print(json.dumps(out))
"""


def test_standard_servers_answer_goal_by_goal(tmp_path: Path, start_robot) -> None:
    domain = random_domain()
    start_robot(domain)
    proc = subprocess.run(
        [sys.executable, "-c", CLIENT, str(tmp_path / "log")],
        env=ros_environ(domain, tmp_path / "log"),
        capture_output=True,
        text=True,
        timeout=300,
        cwd=REPO,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["home"] == [True, "arm folded"]
    from llmpas.worlds.pybullet.scene import HOME_CONF

    assert max(abs(a - b) for a, b in zip(out["joints"], HOME_CONF, strict=True)) < 0.05
    ok, message, believed = out["drive"]
    assert ok and message.startswith("drove")
    assert abs(believed[0] - 0.3) < 1e-6  # odometry: where the robot believes it is
    message, reason, code = out["bad_joints"]
    assert "expected the joints panda_joint1" in message and reason == "aborted" and code == -2
    ok, width, stalled, reached = out["close"]  # closed on air: nothing held
    assert ok and width < 0.01 and not stalled and reached
    ok, width, stalled = out["open"]
    assert ok and width > 0.03 and not stalled
