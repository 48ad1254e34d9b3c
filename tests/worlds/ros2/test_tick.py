"""A tree that keeps ticking while a goal runs, over a real ROS 2 graph: the robot node holds
its ``navigate_to_pose`` goal until it is cancelled; the client's tree polls the goal every
tick, checks a guard, and the guard's failure cancels the goal on the server (which logs it).
Counts, never times. Loopback only: a random domain, discovery on localhost, ROS_LOG_DIR."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

from llmpas.worlds.ros2.env import random_domain
from tests.worlds.ros2.conftest import REPO, ros_environ
from tests.worlds.ros2.tick_client import FAIL_AT

CANCELLED = "the navigate_to_pose goal was cancelled by the client"


def test_the_tree_ticks_while_a_goal_runs_and_a_guard_cancels_it_on_the_server(
    tmp_path: Path, start_robot
) -> None:
    domain = random_domain()
    robot = start_robot(domain, "--stall", "navigate_to_pose")
    out = tmp_path / "tick.json"
    client = subprocess.run(
        [
            sys.executable,
            "-m",
            "tests.worlds.ros2.tick_client",
            str(domain),
            str(tmp_path),
            str(out),
        ],
        env=ros_environ(domain, tmp_path / "client-log"),
        capture_output=True,
        text=True,
        timeout=600,
        cwd=REPO,
    )
    assert client.returncode == 0, client.stderr[-3000:]
    report = json.loads(out.read_text())
    # two drives (the guard failed on the first base: the subtree explored the second)
    assert report["goals"] == 2 and report["status"] == "anomaly"
    # each goal was polled at every tick while it ran, and the guard checked each time
    assert report["checks"] == [FAIL_AT, FAIL_AT]
    assert report["polls"] >= 2 * FAIL_AT >= 2 * 10
    assert report["ticks"] >= report["polls"]
    statuses = [tuple(e[:2]) for e in report["events"]]
    assert statuses.count(("move_base", "cancelled")) == 2
    assert ("drive", "backtrack") in statuses and ("drive", "anomaly") in statuses
    # the server saw both cancels (its log), and is still up
    end = time.monotonic() + 30
    while robot.text().count(CANCELLED) < 2 and time.monotonic() < end:
        time.sleep(0.2)
    text = robot.text()
    assert text.count("stalling a navigate_to_pose goal") == 2
    assert text.count(CANCELLED) == 2, text[-2000:]
    assert robot.proc.poll() is None
