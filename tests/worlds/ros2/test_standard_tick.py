"""The STANDARD client's tick never waits, over a real ROS 2 graph (loopback only: a random
domain, discovery on localhost, ROS_LOG_DIR under the test's folder). Counts, never times:

- the tree ticks while a server is slow to accept a goal (the robot holds acceptance at least
  2 s and until the client's guard has been checked OPEN_AT times) and while a trajectory is
  planned (the planner held until the guard's PLANNED_AT-th check): a tick that waited would
  never get there;
- a guard's failure cancels the goal on the server (its log says so);
- the robot killed mid-grasp ends ``llmpas run --site`` with one line naming the gripper's
  server and ROS_DOMAIN_ID, exit 1, and loop.json keeps every round finished before.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from llmpas.worlds.ros2.env import random_domain
from tests.worlds.ros2.conftest import REPO, llmpas, ros_environ
from tests.worlds.ros2.standard_tick_client import FAIL_AT, OPEN_AT, PLANNED_AT

CANCELLED = "the navigate_to_pose goal was cancelled by the client"
REPLAY = "replay:tests/data/cassettes/qwen1.5b-pybullet-hidden"


def test_the_standard_client_ticks_while_a_goal_is_accepted_and_a_trajectory_planned(
    tmp_path: Path, start_robot
) -> None:
    domain = random_domain()
    gate = tmp_path / "accept-gate"
    robot = start_robot(
        domain, "--standard", "--hold-accept", str(gate), "--accept-after", "2",
        "--stall", "navigate_to_pose",
    )  # fmt: skip
    out = tmp_path / "tick.json"
    client = subprocess.run(
        [sys.executable, "-m", "tests.worlds.ros2.standard_tick_client", str(domain),
         str(tmp_path), str(out), str(gate)],
        env=ros_environ(domain, tmp_path / "client-log"),
        capture_output=True, text=True, timeout=600, cwd=REPO,
    )  # fmt: skip
    assert client.returncode == 0, client.stderr[-3000:]
    report = json.loads(out.read_text())
    # the first goal waited for acceptance while the tree ticked (and polled it) OPEN_AT times
    assert report["polls_accepting_at_open"] >= OPEN_AT - 2 >= 10
    assert "holding a navigate_to_pose goal's acceptance" in robot.text()
    # the server took at least 2 s to accept it (and no fewer than OPEN_AT checks)
    held = [line for line in robot.text().splitlines() if "accepting the held" in line]
    assert held and float(held[0].rsplit("after ", 1)[1].split()[0]) >= 2.0, robot.text()[-3000:]
    # both goals ran until the guard failed at its FAIL_AT-th check, which cancelled them
    assert report["checks_accepted"] == [FAIL_AT, FAIL_AT] and report["goals"] == 2
    assert report["checks"][0] >= FAIL_AT + OPEN_AT - 2  # the first also ticked while held
    assert report["status"] == "anomaly"
    statuses = [tuple(e[:2]) for e in report["events"]]
    assert statuses.count(("move_base", "cancelled")) == 2
    end = time.monotonic() + 30  # the cancels' replies come off the tick's thread
    while robot.text().count(CANCELLED) < 2 and time.monotonic() < end:
        time.sleep(0.2)
    assert robot.text().count(CANCELLED) == 2, robot.text()[-2000:]
    # folding the arm: the tree ticked while its trajectory was planned, then it ended
    assert report["fold_checks"] >= PLANNED_AT and report["polls_planning"] >= PLANNED_AT - 1
    assert report["fold_status"] == "success"
    assert robot.proc.poll() is None


def test_the_robot_killed_mid_grasp_ends_a_site_run_in_one_line_keeping_its_rounds(
    tmp_path: Path, start_robot
) -> None:
    domain = random_domain()
    truth = tmp_path / "truth.json"
    robot = start_robot(domain, "--standard", "--stall", "gripper_cmd", "--truth", str(truth))
    run = llmpas(
        ["run", "object-loss", "--world", "ros2", "--robot-profile", "pybullet-standard",
         "--site", "house", "--llm", REPLAY, "--out", str(tmp_path / "run")],
        domain, tmp_path / "client-log", LLMPAS_ROS_ROBOT="external",
    )  # fmt: skip
    try:
        assert robot.wait_for("stalling a gripper_cmd goal", 600), robot.text()[-2000:]
        running = json.loads((tmp_path / "run" / "loop.json").read_text())
        os.kill(robot.proc.pid, signal.SIGKILL)
        robot.proc.wait(10)
        _, err = run.communicate(timeout=600)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 1, err[-2000:]
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err[-2000:]
    assert lines[0].startswith("error: ")
    assert "/gripper_controller/gripper_cmd" in lines[0] and "vanished" in lines[0], lines[0]
    assert f"ROS_DOMAIN_ID={domain}" in lines[0]
    loop = json.loads((tmp_path / "run" / "loop.json").read_text())
    assert loop["status"] == "robot-lost" and "gripper_cmd" in loop["error"]
    # the rounds finished before the kill are kept (the grasp is in round 2: two before it)
    assert len(loop["rounds"]) == len(running["rounds"]) >= 2
    assert loop["rounds"][0]["status"] == "anomaly"
    assert not truth.exists()  # a killed robot writes no truth
