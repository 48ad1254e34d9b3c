"""The ROS 2 side of a session: an isolated rclpy context of this process, the simulated robot
in a process of its own, and the error a robot that cannot be used is."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from llmpas.errors import ExitCode, LlmpasError
from llmpas.worlds.ros2.env import RosEnv


class RosError(LlmpasError):
    """The robot over ROS 2 cannot be used (a missing server, a node that would not start)."""

    code = ExitCode.FAILED


@contextmanager
def ros_context(env: RosEnv) -> Iterator[Any]:
    """An rclpy context of this process, isolated by ``env`` (variables set first)."""
    env.apply()
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    # Ctrl-C stays a KeyboardInterrupt: the robot cancels its goal before the context ends
    try:
        rclpy.init(
            context=context, domain_id=env.domain, signal_handler_options=SignalHandlerOptions.NO
        )
    except Exception as e:  # rclpy's RCLError: the middleware would not load, say
        rmw = os.environ.get("RMW_IMPLEMENTATION") or "ROS 2's default"
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise RosError(f"ROS 2 did not start with RMW_IMPLEMENTATION={rmw}: {first}") from None
    try:
        yield context
    finally:
        context.try_shutdown()


@contextmanager
def robot_process(
    scenario: str, seed: int, env: RosEnv, folder: Path, faults: tuple[str, ...] = ()
) -> Iterator[subprocess.Popen[bytes]]:
    """The PyBullet robot node in its own process (stopped, then killed, at the end)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = (folder / "robot.log").open("wb")
    cmd = [
        sys.executable,
        "-m",
        "llmpas.worlds.pybullet_ros2",  # the simulated robot, by name: never imported here
        scenario,
        "--seed",
        str(seed),
        "--domain",
        str(env.domain),
        "--log-dir",
        str(folder),
        *faults,
    ]
    proc = subprocess.Popen(cmd, env=env.environ(), stdout=out, stderr=subprocess.STDOUT)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        out.close()


__all__ = ["RosError", "robot_process", "ros_context"]
