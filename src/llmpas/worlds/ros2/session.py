"""The ROS 2 world (``--world ros2``): the PyBullet scenarios, with the robot reached over ROS 2.

By default a session starts the PyBullet robot node (:mod:`llmpas.worlds.ros2.node`) in a
process of its own, on a fresh random ``ROS_DOMAIN_ID`` with discovery kept on localhost, and
stops it at the end. ``LLMPAS_ROS_ROBOT=external`` connects to a robot that is already serving
the actions instead (``llmpas robot pybullet SCENARIO``, or a real robot: docs/ros.md), on
``ROS_DOMAIN_ID`` and the discovery range of ``LLMPAS_ROS_DISCOVERY``.

Planning, the belief and the decomposition are the PyBullet session's (the same seeded
generators: belief ``[seed, 3]``, streams ``[seed, 1]``, context ``[seed, 2]``); the simulator's
own (``[seed, 0]``, ``[seed, 4]``) live in the robot node. The streams reason on a planning
scene, a copy of the robot's scene read after every goal.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.errors import ExitCode, LlmpasError
from llmpas.execution.context import Context
from llmpas.execution.executor import ExecutorConfig
from llmpas.files import atomic_write
from llmpas.worlds.api import RunOptions
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.kitchen.session import PLANNER
from llmpas.worlds.pybullet.camera import CameraConfig
from llmpas.worlds.pybullet.decomposition import ExplorationConfig
from llmpas.worlds.pybullet.plugin import PyBulletSession, table_search
from llmpas.worlds.pybullet.reasoning import prompt_tables, vocabulary
from llmpas.worlds.pybullet.run import (
    PyBulletScenario,
    belief_for,
    resolve,
    scenarios,
    setup_scene,
)
from llmpas.worlds.pybullet.scene import Scene, open_client
from llmpas.worlds.pybullet.streams import Geometry
from llmpas.worlds.ros2.client import RobotUnavailableError, RosRobot, Timeouts
from llmpas.worlds.ros2.env import (
    RosEnv,
    from_environment,
    missing_rmw,
    random_domain,
    reclaim_shared_memory,
)
from llmpas.worlds.ros2.profile import ProfileError, RobotProfile
from llmpas.worlds.ros2.profile import load as load_profile
from llmpas.worlds.ros2.record import McapRecorder, type_name
from llmpas.worlds.ros2.standard_robot import StandardRobot

log = logging.getLogger(__name__)

ROBOT_VAR = "LLMPAS_ROS_ROBOT"  # "external": connect to a running robot, start none
TIMEOUT_VAR = "LLMPAS_ROS_DISCOVER_TIMEOUT"  # seconds to find every server (default 30)
BAG = "ros.mcap"
TOPICS = {  # recorded topics: the profile's topic key -> (package, message)
    "odom": ("nav_msgs.msg", "Odometry"),
    "joint_states": ("sensor_msgs.msg", "JointState"),
    "detections": ("llmpas_interfaces.msg", "Detections"),
    "scene_markers": ("visualization_msgs.msg", "MarkerArray"),
}
STANDARD_TOPICS = {  # a standard robot's
    "odom": ("nav_msgs.msg", "Odometry"),
    "joint_states": ("sensor_msgs.msg", "JointState"),
    "detections": ("vision_msgs.msg", "Detection3DArray"),
    "wrist_detections": ("vision_msgs.msg", "Detection3DArray"),
    "tf": ("tf2_msgs.msg", "TFMessage"),
    "tf_static": ("tf2_msgs.msg", "TFMessage"),
}


class RosError(LlmpasError):
    """The robot over ROS 2 cannot be used (a missing server, a node that would not start)."""

    code = ExitCode.FAILED


class Ros2Session(PyBulletSession):
    """A PyBullet scenario whose robot is reached over ROS 2."""

    def __init__(
        self,
        scenario: PyBulletScenario,
        plugin: Ros2Plugin,
        options: RunOptions,
        client: int,
        context: Any,
        folder: Path,
        profile: RobotProfile,
    ) -> None:
        self.scenario = scenario
        self.seed = scenario.seed if options.seed is None else options.seed
        self.planner = options.planner or PLANNER
        self.executor = options.executor or ExecutorConfig()
        self.exploration = plugin.exploration
        self.timings: dict[str, float] = {}
        self.folder = folder
        t0 = time.perf_counter()
        self.profile = profile
        self.scene = Scene(client, scenario.scene)  # the planning scene
        self.bag = McapRecorder(folder / BAG)
        self.robot: RosRobot | StandardRobot
        if profile.standard:  # llmpas's own planning scene: the scenario's layout to start
            setup_scene(self.scene, scenario)
            rng = np.random.default_rng([self.seed, 0])
            self.robot = StandardRobot(
                context, self.scene, profile, rng, plugin.timeouts, self._record_goal
            )
        else:
            self.robot = RosRobot(context, self.scene, plugin.timeouts, self._record_goal, profile)
        self.world = self.robot  # type: ignore[assignment]  # what PyBulletSession reads
        self.saved = False
        topics = STANDARD_TOPICS if profile.standard else TOPICS
        try:
            self.subscriptions = [self._subscribe(t, *m) for t, m in topics.items()]
            self.robot.wait_for_servers()
        except BaseException:
            self.bag.close()
            self.robot.shutdown()
            raise
        self.timings["connect"] = time.perf_counter() - t0
        belief = belief_for(self.scene, scenario, np.random.default_rng([self.seed, 3]))
        self.geometry = Geometry(self.scene, np.random.default_rng([self.seed, 1]))
        self.context = Context(
            self.robot, self.robot, belief, np.random.default_rng([self.seed, 2])
        )
        self.domain = load_domain()
        self.vocabulary = vocabulary(scenario.scene)
        self.prompts = prompt_tables(scenario.scene)
        self.search = table_search(scenario.scene, belief)
        self.rounds = 0
        self.episodes = 0
        self.anomalies = 0
        self._recorder: Any = self.context.recorder
        self._seen = 0
        self.robot.clock = lambda: (self.rounds, len(self.context.recorder.events))

    # ------------------------------------------------------------------ recording

    def _subscribe(self, key: str, module: str, name: str) -> Any:
        """Record the profile's topic ``key`` with the profile's QoS (a subscription that asks
        more than the publisher offers, RELIABLE of a best-effort one or TRANSIENT_LOCAL of a
        VOLATILE one, gets nothing)."""
        import importlib

        kind = getattr(importlib.import_module(module), name)
        topic = getattr(self.profile.topics, key)
        full = f"{module.split('.')[0]}/msg/{name}"
        channel = self.robot.node.resolve_topic_name(topic.name)
        return self.robot.node.create_subscription(
            kind, topic.name, lambda msg: self.bag.write(channel, full, msg), topic.qos.rclpy()
        )

    def _record_goal(self, channel: str, kind: str, msg: Any) -> None:
        namespace = self.profile.namespace
        if namespace and not channel.startswith(namespace + "/"):
            channel = namespace + channel  # the llmpas client's channels are relative
        self.bag.write(channel, type_name(msg), msg)
        if kind == "Goal":
            self._record_anomalies()

    def _record_anomalies(self) -> None:
        """The executor's anomalies so far (its timeline, one per round), as
        DiagnosticArray messages on ``/diagnostics``."""
        current = self.context.recorder
        if current is not self._recorder:
            self._flush(self._recorder)
            self._recorder, self._seen = current, 0
        self._flush(current)

    def _flush(self, recorder: Any) -> None:
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        if recorder is None:
            return
        events = recorder.events
        if recorder is not self._recorder:
            start = self._seen
        else:
            start, self._seen = self._seen, len(events)
        for e in events[start:]:
            if e.status != "anomaly":
                continue
            status = DiagnosticStatus()
            status.level, status.name = DiagnosticStatus.ERROR, f"llmpas/anomaly/{e.node}"
            status.message, status.hardware_id = e.message, "llmpas"
            status.values = [KeyValue(key=k, value=v) for k, v in e.values.items()]
            msg = DiagnosticArray()
            msg.status = [status]
            self.bag.write("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", msg)
            self.anomalies += 1

    # ------------------------------------------------------------------ files

    def save(self, folder: Path) -> list[Path]:
        """The MCAP (moved into the run folder; recording goes on there) and ``ros.json``."""
        self._record_anomalies()
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        self.rounds = self.episodes
        about = {
            "scenario": self.name,
            "achieved": self.achieved(),
            "timings": self.timings,
            "goals": self.robot.goals,
            "environment": {  # this process's, set before rclpy started
                k: os.environ.get(k, "")
                for k in (
                    "ROS_AUTOMATIC_DISCOVERY_RANGE",
                    "ROS_DOMAIN_ID",
                    "ROS_LOG_DIR",
                    "RMW_IMPLEMENTATION",
                )
            },
            "anomalies": self.anomalies,
            "bag": BAG,
            "channels": {
                t: {"type": self.bag.types[t], "messages": n}
                for t, n in sorted(self.bag.counts.items())
            },
            "profile": {
                "name": self.profile.name,
                "interfaces": self.profile.interfaces,
                "namespace": self.profile.namespace,
                "file": self.profile.source,
            },
            "holds": "the goals, feedback and results of every action, the robot's odometry, "
            "joint states, detections and scene markers (a standard robot's: TF), and each "
            "anomaly as diagnostic_msgs/DiagnosticArray on /diagnostics",
        }
        artifact = {
            "file": BAG,
            "title": "ROS 2 recording (rosbag2 MCAP: Foxglove, ros2 bag)",
            "holds": about["holds"],
        }
        written = [
            atomic_write(folder / "ros.json", json.dumps(about, indent=2)),
            atomic_write(folder / "artifacts.json", json.dumps([artifact], indent=2)),
        ]
        self.bag.close()
        target = folder / BAG
        if self.bag.path.resolve() != target.resolve():
            shutil.copyfile(self.bag.path, target)
        written.append(target)
        for name in ("robot.log", "log"):  # the robot node's output and the ROS logs
            source = self.folder / name
            if source.is_file():
                written.append(Path(shutil.copyfile(source, folder / f"ros-{name}")))
            elif source.is_dir():
                shutil.copytree(source, folder / "ros-log", dirs_exist_ok=True)
        self.saved = True
        return written


@dataclass(frozen=True)
class Ros2Plugin:
    """The ROS 2 world: the PyBullet scenarios over ROS 2."""

    camera: CameraConfig = field(default_factory=CameraConfig)
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    timeouts: Timeouts = field(default_factory=Timeouts)
    name: str = "ros2"
    title: str = "ROS 2: the PyBullet Husky + Franka Panda as a ROS 2 robot"

    def scenarios(self) -> dict[str, str]:
        return {name: s.description for name, s in scenarios().items()}

    @contextmanager
    def open(self, scenario: Any, options: RunOptions) -> Iterator[Ros2Session]:
        chosen = resolve(scenario)
        seed = chosen.seed if options.seed is None else options.seed
        plugin = self
        wait = os.environ.get(TIMEOUT_VAR, "").strip()
        if wait:
            try:
                plugin = replace(self, timeouts=replace(self.timeouts, discover=float(wait)))
            except ValueError:
                raise RosError(f"{TIMEOUT_VAR}={wait!r}: not a number of seconds") from None
        try:
            profile = load_profile(options.robot_profile or "pybullet")
        except ProfileError as e:
            raise RosError(str(e)) from None
        reclaimed = reclaim_shared_memory()  # what killed nodes left in /dev/shm
        if reclaimed:
            log.info("removed %d shared-memory segments of ended ROS 2 processes", reclaimed)
        folder = Path(tempfile.mkdtemp(prefix="llmpas-ros2-"))
        external = os.environ.get(ROBOT_VAR, "").strip().lower() == "external"
        try:
            env = (
                from_environment(folder / "log", rmw=profile.rmw)
                if external
                else RosEnv(random_domain(), folder / "log", rmw=profile.rmw)
            )
        except ValueError as e:
            raise RosError(str(e)) from None
        problem = missing_rmw(env.environ())
        if problem is not None:
            raise RosError(problem)
        with ExitStack() as stack:
            if not external:
                extra = ("--robot-profile", profile.source) if profile.source else ()
                stack.enter_context(robot_process(chosen.name, seed, env, folder, extra))
            context = stack.enter_context(ros_context(env))
            client = stack.enter_context(open_client(False))
            try:
                session = Ros2Session(chosen, plugin, options, client, context, folder, profile)
            except RobotUnavailableError as e:
                hint = "" if external else f" (the robot node did not come up: {folder}/robot.log)"
                raise RosError(f"{e}{hint}; ROS_DOMAIN_ID={env.domain}") from None
            try:
                yield session
            finally:
                session.bag.close()
                session.robot.shutdown()
        # the session's folder: copied into the run folder by save(); else kept (an interrupted
        # run without a run folder still has its recording there)
        if session.saved:
            shutil.rmtree(folder, ignore_errors=True)
        else:
            log.info("the ROS 2 recording and logs are in %s", folder)


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
        "llmpas.worlds.ros2.node",
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


WORLD = Ros2Plugin()

__all__ = ["BAG", "ROBOT_VAR", "WORLD", "Ros2Plugin", "Ros2Session", "RosError", "robot_process"]
