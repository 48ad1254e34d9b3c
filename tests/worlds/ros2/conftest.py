"""The ROS 2 tests run a real ROS 2 graph: the PyBullet robot node and ``llmpas run`` in
processes of their own, each on a random ROS_DOMAIN_ID with discovery on localhost and its log
folder under the test's tmp_path. They need the ``ros`` extra (``pip install -e ".[ros]"``):
without it they skip, unless ``LLMPAS_REQUIRE_ROS=1`` (set by ``.ci/run``, which installs it) or
``CI`` is set; there a missing extra is a failure."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from llmpas.reporting import browser


def _missing() -> str | None:
    try:
        import control_msgs.action  # noqa: F401
        import llmpas_interfaces.action  # noqa: F401
        import mcap_ros2  # noqa: F401
        import nav2_msgs.action  # noqa: F401
        import rclpy  # noqa: F401
    except ImportError as e:
        return f'the ros extra is not installed ({e}; pip install -e ".[ros]")'
    return None


@pytest.fixture(autouse=True)
def _ros_installed() -> None:
    missing = _missing()
    if missing is None:
        return
    if os.environ.get("LLMPAS_REQUIRE_ROS") == "1" or browser.in_ci():
        pytest.fail(missing)
    pytest.skip(missing)


REPO = Path(__file__).resolve().parents[3]


def ros_environ(domain: int, log_dir: Path, **extra: str) -> dict[str, str]:
    from llmpas.worlds.ros2.env import RosEnv

    env = RosEnv(domain, log_dir).environ()
    env["PYTHONPATH"] = os.pathsep.join([str(REPO / "src"), env.get("PYTHONPATH", "")])
    env.update(extra)
    return env


class Robot:
    """The PyBullet robot node in its own process (its output in ``log``)."""

    def __init__(self, proc: subprocess.Popen[bytes], log: Path) -> None:
        self.proc, self.log = proc, log

    def text(self) -> str:
        return self.log.read_text(errors="replace") if self.log.exists() else ""

    def wait_for(self, needle: str, seconds: float) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if needle in self.text():
                return True
            if self.proc.poll() is not None:
                return False
            time.sleep(0.2)
        return False


@pytest.fixture
def start_robot(tmp_path: Path) -> Iterator:
    started: list[Robot] = []

    def start(domain: int, *faults: str, scenario: str = "object-loss") -> Robot:
        folder = tmp_path / f"robot-{len(started)}"
        folder.mkdir()
        log = folder / "robot.log"
        cmd = [
            sys.executable, "-m", "llmpas.cli", "robot", "pybullet", scenario,
            "--domain", str(domain), "--log-dir", str(folder), *faults,
        ]  # fmt: skip
        out = log.open("wb")
        proc = subprocess.Popen(
            cmd, env=ros_environ(domain, folder / "ros"), stdout=out, stderr=subprocess.STDOUT
        )
        robot = Robot(proc, log)
        started.append(robot)
        assert robot.wait_for("serving", 120), robot.text()
        return robot

    yield start
    for r in started:
        if r.proc.poll() is None:
            r.proc.send_signal(signal.SIGTERM)
            try:
                r.proc.wait(10)
            except subprocess.TimeoutExpired:
                r.proc.kill()
                r.proc.wait()


def llmpas(
    args: list[str], domain: int, log_dir: Path, timeout: float = 900, **extra: str
) -> subprocess.Popen[str]:
    """``llmpas ARGS`` in its own process, its environment isolated like a node's."""
    env = ros_environ(domain, log_dir, **extra)
    return subprocess.Popen(
        [sys.executable, "-X", "faulthandler", "-m", "llmpas.cli", *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )
