"""The closed loop over a real ROS 2 graph: the PyBullet robot node and ``llmpas run`` in
processes of their own, on a random domain, discovery on localhost. The LLM is the labelled
oracle (an upper bound) or a recorded offline model (a cassette)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from llmpas.worlds.ros2.env import random_domain
from tests.worlds.ros2.conftest import REPO, llmpas

CASSETTE = "replay:tests/data/cassettes/qwen1.5b-pybullet-hidden"


def _environ(pid: int) -> dict[str, str]:
    raw = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    return dict(item.decode().split("=", 1) for item in raw if b"=" in item)


def _rounds(folder: Path) -> list[tuple[str, str]]:
    loop = json.loads((folder / "loop.json").read_text())
    return [(r["goal"], r["status"]) for r in loop["rounds"]]


def test_replayed_model_over_ros_gives_the_in_process_run(tmp_path: Path) -> None:
    """The must-show run: object-loss against the robot node (started by the same command)
    with the replayed offline model ends "task done" with the in-process run's rounds and
    goals, and its MCAP holds the goals and the anomaly."""
    domain = random_domain()
    ros = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            CASSETTE,
            "--out",
            str(tmp_path / "ros"),
        ],
        domain,
        tmp_path / "ros-log",
    )
    local = llmpas(
        ["run", "object-loss", "--llm", CASSETTE, "--out", str(tmp_path / "local")],
        domain,
        tmp_path / "local-log",
    )
    out, err = ros.communicate(timeout=900)
    _, local_err = local.communicate(timeout=900)
    assert ros.returncode == 0, err[-2000:]
    assert local.returncode == 0, local_err[-2000:]
    assert out.strip().splitlines()[-1].startswith("task done")
    assert _rounds(tmp_path / "ros") == _rounds(tmp_path / "local")
    assert len(_rounds(tmp_path / "ros")) >= 2  # an anomaly was recovered from

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    topics: dict[str, list] = {}
    with (tmp_path / "ros" / "ros.mcap").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            topics.setdefault(channel.topic, []).append(msg)
    goals = topics["/navigate_to_pose/goal"]
    assert goals and all(g.pose.header.frame_id == "map" for g in goals)
    assert topics["/llmpas/look/result"] and topics["/joint_states"] and topics["/odom"]
    anomalies = [s for a in topics["/diagnostics"] for s in a.status]
    assert anomalies and "cube not detected" in anomalies[0].message
    assert anomalies[0].level == 2  # ERROR
    assert topics["/scene_markers"][-1].markers
    about = json.loads((tmp_path / "ros" / "ros.json").read_text())
    assert about["channels"]["/diagnostics"]["messages"] == len(topics["/diagnostics"])
    page = (tmp_path / "ros" / "index.html").read_text()
    assert "ros.mcap" in page


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(c) for c in (task / "children").read_text().split()]
    return found


def test_every_node_keeps_discovery_on_localhost_in_its_own_domain(tmp_path: Path) -> None:
    """``llmpas run --world ros2`` started with discovery widened and a domain of the user's:
    the run and the robot node it starts both keep discovery on localhost, on one random
    domain of their own, with their logs in their folders; the run still ends "task done"."""
    run = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            "oracle",
            "--out",
            str(tmp_path / "run"),
        ],
        random_domain(),
        tmp_path / "client-log",
        ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET",
        ROS_LOCALHOST_ONLY="1",
    )
    try:
        robot: dict[str, str] = {}
        for _ in range(600):
            child = next(iter(_children(run.pid)), None)
            robot = _environ(child) if child is not None else {}
            if "ROS_DOMAIN_ID" in robot:
                break
            time.sleep(0.1)
        _, err = run.communicate(timeout=900)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 0, err[-2000:]
    assert robot, "the run started no robot node"
    client = json.loads((tmp_path / "run" / "ros.json").read_text())["environment"]
    for env in (robot, client):
        assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
        assert env["ROS_DOMAIN_ID"] == robot["ROS_DOMAIN_ID"]
        assert Path(env["ROS_LOG_DIR"]).name == "log"
    assert "ROS_LOCALHOST_ONLY" not in robot
    assert 1 <= int(robot["ROS_DOMAIN_ID"]) <= 101
    assert (tmp_path / "run" / "ros-log").is_dir()  # the run's ROS logs, in the run folder


def test_killed_robot_node_ends_the_run_naming_the_server_and_loop_json_keeps_every_round(
    tmp_path: Path, start_robot
) -> None:
    """SIGKILL the robot node in mid-action: a dead robot is an error, not an anomaly. The run
    ends with one line naming the vanished server and the domain (exit 1), the LLM is not asked
    about it, and loop.json keeps every round run before. Every process's environment keeps
    discovery on localhost, its own domain and its log folder under the test's folder."""
    domain = random_domain()
    robot = start_robot(domain, "--stall", "grasp")
    run = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            "oracle",
            "--out",
            str(tmp_path / "run"),
        ],
        domain,
        tmp_path / "client-log",
        LLMPAS_ROS_ROBOT="external",
    )
    try:
        assert robot.wait_for("stalling a grasp goal", 600), robot.text()[-2000:]
        for pid, log in ((robot.proc.pid, tmp_path), (run.pid, tmp_path / "client-log")):
            env = _environ(pid)
            assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
            assert env["ROS_DOMAIN_ID"] == str(domain)
            assert Path(env["ROS_LOG_DIR"]).is_relative_to(log)
        running = json.loads((tmp_path / "run" / "loop.json").read_text())
        os.kill(robot.proc.pid, signal.SIGKILL)
        robot.proc.wait(10)
        _, err = run.communicate(timeout=900)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 1, err[-2000:]
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err[-2000:]
    assert "/llmpas/skill" in lines[0] and "vanished" in lines[0], lines[0]
    assert f"ROS_DOMAIN_ID={domain}" in lines[0]
    loop = json.loads((tmp_path / "run" / "loop.json").read_text())
    assert loop["status"] == "robot-lost" and "/llmpas/skill" in loop["error"]
    # every round run before the kill is kept, and no LLM round came after it
    assert len(loop["rounds"]) >= len(running["rounds"]) >= 1
    assert loop["rounds"][0]["status"] == "anomaly"
    assert len(loop["rounds"]) == len(running["rounds"])
    # a fresh run right after the kill is not disturbed by what it left (/dev/shm/fastdds_*)
    fresh = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            "oracle",
            "--out",
            str(tmp_path / "after"),
        ],
        random_domain(),
        tmp_path / "after-log",
    )
    fresh_out, fresh_err = fresh.communicate(timeout=900)
    assert fresh.returncode == 0, fresh_err[-2000:]
    assert fresh_out.strip().splitlines()[-1].startswith("task done")


def test_ctrl_c_cancels_the_goal_on_the_robot(tmp_path: Path, start_robot) -> None:
    domain = random_domain()
    robot = start_robot(domain, "--stall", "grasp")
    run = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            "oracle",
            "--out",
            str(tmp_path / "run"),
        ],
        domain,
        tmp_path / "client-log",
        LLMPAS_ROS_ROBOT="external",
    )
    try:
        assert robot.wait_for("stalling a grasp goal", 600), robot.text()[-2000:]
        run.send_signal(signal.SIGINT)
        try:
            _, err = run.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            run.send_signal(signal.SIGABRT)  # faulthandler: every thread's stack
            pytest.fail("the run did not end after Ctrl-C:\n" + run.communicate(timeout=30)[1])
    finally:
        if run.poll() is None:
            run.kill()
    assert robot.wait_for("the grasp goal was cancelled by the client", 30), robot.text()[-2000:]
    assert run.returncode == 130, err[-2000:]
    assert "Traceback" not in err
    assert robot.proc.poll() is None  # the robot is still up, its goal cancelled


def test_rejected_goal_is_a_skill_failure_the_subtree_explores(tmp_path: Path, start_robot) -> None:
    domain = random_domain()
    start_robot(domain, "--reject", "navigate_to_pose")
    run = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            "oracle",
            "--out",
            str(tmp_path / "run"),
        ],
        domain,
        tmp_path / "client-log",
        LLMPAS_ROS_ROBOT="external",
    )
    _, err = run.communicate(timeout=900)
    assert run.returncode == 1, err[-2000:]
    assert "Traceback" not in err
    loop = json.loads((tmp_path / "run" / "loop.json").read_text())
    assert loop["rounds"] and loop["rounds"][0]["status"] == "anomaly"
    text = (tmp_path / "run" / "loop.md").read_text()
    assert "rejected the goal" in text
    # the subtree explored: more than one drive was tried before the anomaly
    events = (tmp_path / "run" / "round-0").rglob("*.json")
    tried = sum(f.read_text().count("rejected the goal") for f in events)
    assert tried > 1


def test_missing_server_and_another_domain_are_named_within_a_deadline(
    tmp_path: Path, start_robot
) -> None:
    """A robot serving on one domain is not seen from another: the missing action server is
    named in one line, with a non-zero exit, within the deadline."""
    domain = random_domain()
    start_robot(domain)
    other = domain % 101 + 1
    run = llmpas(
        [
            "run",
            "object-loss",
            "--world",
            "ros2",
            "--llm",
            "oracle",
            "--out",
            str(tmp_path / "run"),
        ],
        other,
        tmp_path / "client-log",
        LLMPAS_ROS_ROBOT="external",
        LLMPAS_ROS_DISCOVER_TIMEOUT="5",
    )
    _, err = run.communicate(timeout=120)  # the deadline: 5 s to find the servers
    assert run.returncode == 1
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    assert "/navigate_to_pose" in lines[0] and f"ROS_DOMAIN_ID={other}" in lines[0]
    assert "Traceback" not in err


def test_robot_node_names_a_bad_scenario(tmp_path: Path) -> None:
    from tests.worlds.ros2.conftest import ros_environ

    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "llmpas.cli",
            "robot",
            "pybullet",
            "no-such-scenario",
            "--log-dir",
            str(tmp_path),
        ],
        env=ros_environ(random_domain(), tmp_path),
        capture_output=True,
        text=True,
        timeout=120,
        cwd=REPO,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert "no-such-scenario" in proc.stderr
