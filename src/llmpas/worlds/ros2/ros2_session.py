"""The ROS 2 world (``--world ros2``): the PyBullet scenarios, with the robot reached over ROS 2.

By default a session starts the PyBullet robot node (:mod:`llmpas.worlds.pybullet_ros2.node`) in a
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

import time
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.context import Context
from llmpas.execution.executor import ExecutorConfig
from llmpas.worlds.api import RunOptions
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.kitchen.kitchen_session import PLANNER
from llmpas.worlds.pybullet.pybullet_plugin import PyBulletSession, table_search
from llmpas.worlds.pybullet.pybullet_reasoning import prompt_tables, vocabulary
from llmpas.worlds.pybullet.pybullet_scenarios import PyBulletScenario, belief_for, setup_scene
from llmpas.worlds.pybullet.pybullet_streams import Geometry
from llmpas.worlds.pybullet.scene import Scene
from llmpas.worlds.ros2.client import RosRobot
from llmpas.worlds.ros2.process import RosError, robot_process, ros_context
from llmpas.worlds.ros2.profile import RobotProfile
from llmpas.worlds.ros2.recording import BAG, Recording
from llmpas.worlds.ros2.rosbag import McapRecorder
from llmpas.worlds.ros2.standard_robot import StandardRobot

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


class Ros2Session(Recording, PyBulletSession):
    """A PyBullet scenario whose robot is reached over ROS 2."""

    def __init__(
        self,
        scenario: PyBulletScenario,
        plugin: Any,
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
        # a standard robot gives no ground truth: its verdict is judged on the planning scene,
        # what it perceived; the llmpas-interfaces robot answers its (simulator's) scene
        self.verdict_basis = "perceived" if profile.standard else "truth"
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

    def about(self) -> dict[str, Any]:
        return {"verdict": self.verdict_basis}


__all__ = [
    "BAG",
    "STANDARD_TOPICS",
    "TOPICS",
    "Ros2Session",
    "RosError",
    "robot_process",
    "ros_context",
]
