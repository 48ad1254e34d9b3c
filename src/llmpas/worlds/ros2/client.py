"""The robot and its perception over ROS 2: every skill the executor calls is an action goal.

:class:`RosRobot` is an :class:`~llmpas.execution.world.Robot` and a
:class:`~llmpas.execution.world.Perception` whose calls become goals of the robot's action
servers (names in :mod:`llmpas.worlds.ros2.node`): the base is Nav2's ``NavigateToPose``, the
arm's named configuration (home) ros2_control's ``FollowJointTrajectory``, the rest the project's
``Skill`` and ``Look`` actions. A goal is sent, then polled while the node's executor spins in
its own thread (feedback and topics keep arriving); a rejected goal, an abort, a timeout or a
server that disappears is a skill failure with that reason, which the subtree explores like any
other. Ctrl-C cancels the goal on the robot before it ends the run.

After every goal the robot's state (odometry, the held object, the planning scene) is read with
the ``scene_state`` service; the planning scene is the one the streams reason on.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from llmpas.execution.world import Observation, SkillResult
from llmpas.worlds.pybullet.scene import Scene
from llmpas.worlds.pybullet.values import ArmGoal, BaseConf, ObjectPose
from llmpas.worlds.ros2 import convert
from llmpas.worlds.ros2.node import ACTIONS, FJT, GRIPPER, LOOK, NAV, SKILL, STATE, action_names
from llmpas.worlds.ros2.profile import RobotProfile

log = logging.getLogger(__name__)


REQUIRED = (NAV, FJT, SKILL, LOOK)  # what the loop calls (the gripper action is optional)


class RobotUnavailableError(Exception):
    """An action server or service of the robot did not appear in time (names it)."""


@dataclass(frozen=True)
class Timeouts:
    """Seconds: to find every server at start, for a goal to be accepted, for a goal to end,
    and for a server that vanished mid-goal to come back."""

    discover: float = 30.0
    accept: float = 30.0
    goal: float = 300.0
    lost: float = 3.0


class RosRobot:
    """Skills and perception of a robot over ROS 2 (an rclpy node in its own context)."""

    def __init__(
        self,
        context: Any,
        scene: Scene,
        timeouts: Timeouts | None = None,
        on_goal: Callable[[str, str, Any], None] | None = None,
        profile: RobotProfile | None = None,
    ) -> None:
        import rclpy
        from control_msgs.action import FollowJointTrajectory, GripperCommand
        from llmpas_interfaces.action import Look, Skill
        from llmpas_interfaces.srv import GetSceneState
        from nav2_msgs.action import NavigateToPose
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor

        self.scene = scene  # the planning scene, mirrored from the robot after every goal
        self.timeouts = timeouts or Timeouts()
        self.on_goal = on_goal or (lambda channel, kind, msg: None)
        self.profile = profile or RobotProfile()
        self.node = rclpy.create_node(
            "llmpas_client", context=context, namespace=self.profile.namespace or None
        )
        self.types = {
            NAV: NavigateToPose,
            FJT: FollowJointTrajectory,
            GRIPPER: GripperCommand,
            SKILL: Skill,
            LOOK: Look,
        }
        names = action_names(self.profile)
        self.clients = {n: ActionClient(self.node, t, names[n]) for n, t in self.types.items()}
        self.state_client = self.node.create_client(GetSceneState, self.profile.actions.state)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.spinner = threading.Thread(target=self._spin, daemon=True, name="ros2-spin")
        self.spinner.start()
        self.believed: tuple[float, float, float] = scene.config.base
        self.lost: set[str] = set()
        self.log: list[str] = []
        self.frames: list[Any] = []  # the run folder's media: none (the robot keeps its own)
        self.images: list[Any] = []
        self.clock: Callable[[], tuple[int, int]] = lambda: (0, 0)
        self.goals = 0

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # the context was shut down under it
            log.debug("ROS 2 spinner stopped", exc_info=True)

    def shutdown(self) -> None:
        """Stop spinning; the node goes with its context (never blocks on a busy spinner)."""
        self.executor.shutdown(timeout_sec=2.0)
        self.spinner.join(timeout=2.0)
        if not self.spinner.is_alive():
            self.node.destroy_node()

    # ------------------------------------------------------------------ connection

    def wait_for_servers(self) -> None:
        """Every action server and the state service, within ``timeouts.discover`` (else
        :class:`RobotUnavailableError` naming the first missing one)."""
        deadline = time.monotonic() + self.timeouts.discover
        for name in REQUIRED:
            client = self.clients[name]
            if not client.wait_for_server(timeout_sec=max(0.0, deadline - time.monotonic())):
                raise RobotUnavailableError(
                    f"no ROS 2 action server /{name} ({self.types[name].__module__.split('.')[0]}"
                    f"/{self.types[name].__name__}) within {self.timeouts.discover:g} s"
                )
        while not self.sync():  # the first answer: requests and replies both matched
            if time.monotonic() > deadline:
                raise RobotUnavailableError(
                    f"no answer from the ROS 2 service /{STATE} within {self.timeouts.discover:g} s"
                )
            self.state_client.wait_for_service(timeout_sec=0.5)

    def sync(self) -> bool:
        """Read the robot's state into the planning scene (False: the robot did not answer)."""
        from llmpas_interfaces.srv import GetSceneState

        if not self.state_client.service_is_ready():
            return False
        future = self.state_client.call_async(GetSceneState.Request())
        if not self._wait(future, self.timeouts.accept):
            self.state_client.remove_pending_request(future)
            return False
        self.believed = convert.apply_state(self.scene, future.result().state)
        return True

    def _wait(self, future: Any, seconds: float) -> bool:
        end = time.monotonic() + seconds
        while not future.done():
            if time.monotonic() > end:
                return False
            time.sleep(0.002)
        return True

    # ------------------------------------------------------------------ goals

    def goal(self, name: str, goal: Any) -> tuple[SkillResult | None, Any]:
        """Send ``goal`` to ``/name`` and wait for its end, polling (the spinner thread takes
        feedback). (None, result) when it succeeded; (failure, result or None) otherwise."""
        client = self.clients[name]
        if self.lost and not client.server_is_ready():  # the robot went away: fail at once
            self.lost.add(name)
            return SkillResult.failure(f"the robot's /{name} server is gone", reason="lost"), None
        if not client.wait_for_server(timeout_sec=self.timeouts.accept):
            self.lost.add(name)
            return SkillResult.failure(f"no /{name} action server", reason="lost"), None
        self.goals += 1
        self.on_goal(f"/{name}/goal", "Goal", goal)
        sent = client.send_goal_async(
            goal,
            feedback_callback=lambda f: self.on_goal(f"/{name}/feedback", "Feedback", f.feedback),
        )
        try:
            if not self._wait(sent, self.timeouts.accept):
                self.lost.add(name)
                return SkillResult.failure(f"/{name} did not answer the goal", reason="lost"), None
            handle = sent.result()
            if not handle.accepted:
                return SkillResult.failure(f"/{name} rejected the goal", reason="rejected"), None
            return self._result(name, client, handle)
        except KeyboardInterrupt:
            if sent.done() and sent.result().accepted:
                log.warning("cancelling the /%s goal on the robot", name)
                cancel = sent.result().cancel_goal_async()
                self._wait(cancel, 2.0)
            raise

    def _result(self, name: str, client: Any, handle: Any) -> tuple[SkillResult | None, Any]:
        from action_msgs.msg import GoalStatus

        future = handle.get_result_async()
        end = time.monotonic() + self.timeouts.goal
        gone: float | None = None
        while not future.done():
            now = time.monotonic()
            if now > end:
                self._wait(handle.cancel_goal_async(), 2.0)
                return SkillResult.failure(f"/{name} timed out", reason="timeout"), None
            if client.server_is_ready():
                gone = None
            elif gone is None:
                gone = now
            elif now - gone > self.timeouts.lost:
                self.lost.add(name)
                return SkillResult.failure(f"the /{name} server vanished", reason="lost"), None
            time.sleep(0.002)
        wrapped = future.result()
        self.on_goal(f"/{name}/result", "Result", wrapped.result)
        self.sync()
        if wrapped.status == GoalStatus.STATUS_SUCCEEDED:
            return None, wrapped.result
        what = {GoalStatus.STATUS_ABORTED: "aborted", GoalStatus.STATUS_CANCELED: "canceled"}
        return _failure(wrapped.result, what.get(wrapped.status, "failed")), wrapped.result

    # ------------------------------------------------------------------ Robot

    def base_conf(self) -> BaseConf:
        x, y, t = self.believed
        return BaseConf(x, y, t)

    def holding(self) -> str | None:
        return self.scene.held

    def move_base(self, conf: Any) -> SkillResult:
        if not isinstance(conf, BaseConf):
            return SkillResult.failure(f"not a base configuration: {conf!r}", reason="bad_value")
        goal = self.types[NAV].Goal()
        goal.pose = convert.pose_stamped(conf.x, conf.y, 0.0, conf.theta)
        failed, result = self.goal(NAV, goal)
        return failed or _success(result.error_msg)

    def move_arm(self, target: Any) -> SkillResult:
        if isinstance(target, str) and target == "home":
            return self._joints(self.profile.arm.home)
        if not isinstance(target, ArmGoal):
            return SkillResult.failure(f"not an arm goal: {target!r}", reason="bad_value")
        return self._skill("move_arm", convert.arm_goal_json(target))

    def _joints(self, q: tuple[float, ...]) -> SkillResult:
        from trajectory_msgs.msg import JointTrajectoryPoint

        goal = self.types[FJT].Goal()
        goal.trajectory.header.frame_id = "base_link"
        goal.trajectory.joint_names = list(self.profile.arm.joints)
        point = JointTrajectoryPoint()
        point.positions = [float(v) for v in q]
        point.time_from_start.sec = 3
        goal.trajectory.points = [point]
        failed, result = self.goal(FJT, goal)
        return failed or _success(result.error_string)

    def _skill(self, skill: str, args: str) -> SkillResult:
        goal = self.types[SKILL].Goal()
        goal.skill, goal.args = skill, args
        failed, result = self.goal(SKILL, goal)
        if failed is not None:
            return failed
        return SkillResult.success(result.message)

    def grasp(self, obj: str, grasp: Any) -> SkillResult:
        return self._skill("grasp", json.dumps({"obj": obj, "grasp": grasp.kind}))

    def release(self, obj: str, pose: Any) -> SkillResult:
        if not isinstance(pose, ObjectPose):
            return SkillResult.failure(f"not a pose: {pose!r}", reason="bad_value")
        spot = [pose.region, pose.x, pose.y, pose.z]
        return self._skill("release", json.dumps({"obj": obj, "pose": spot}))

    def open(self, container: str) -> SkillResult:
        return self._skill("open", json.dumps({"container": container}))

    def close(self, container: str) -> SkillResult:
        return self._skill("close", json.dumps({"container": container}))

    def process(self, obj: str, appliance: str, how: str) -> SkillResult:
        return self._skill("process", json.dumps({"obj": obj, "appliance": appliance, "how": how}))

    def snapshot(self, label: str) -> None:
        """Images stay with the robot (its camera topics); nothing to keep here."""

    # ------------------------------------------------------------------ Perception

    def _look(self, camera: str, region: str | None, target: str = "") -> Observation | None:
        goal = self.types[LOOK].Goal()
        goal.camera, goal.region, goal.target = camera, region or "", target
        failed, result = self.goal(LOOK, goal)
        if failed is not None:
            log.warning("look with the %s camera failed: %s", camera, failed.message)
            return None
        return convert.observation(result.detections)

    def look(self, target: str | None = None) -> Observation:
        return self._look("mast", target) or Observation(())

    def look_with_arm(self, target: str | None = None) -> Observation:
        return self._look("arm", target) or Observation(())

    def wrist_detect(self, obj: str) -> ObjectPose | None:
        obs = self._look("wrist", None, obj)
        d = None if obs is None else obs.find(obj)
        return d.pose if d is not None and isinstance(d.pose, ObjectPose) else None


def _success(text: str) -> SkillResult:
    message, _, _ = _parse(text)
    return SkillResult.success(message)


def _failure(result: Any, status: str) -> SkillResult:
    """A failed goal's result as a skill failure: its message and reason when it carries them
    (the project's servers), else the goal's status as the reason (a real robot's text)."""
    if hasattr(result, "reason"):  # the project's Skill action
        message, reason, ours = result.message, result.reason, True
    else:
        text = getattr(result, "error_msg", None) or getattr(result, "error_string", "") or ""
        message, reason, ours = _parse(text)
    if not ours:
        return SkillResult.failure(message or f"goal {status}", reason=reason or status)
    return SkillResult.failure(message, reason=reason) if reason else SkillResult.failure(message)


def _parse(text: str) -> tuple[str, str, bool]:
    """Our servers put ``{"message", "reason"}`` in a standard result's text; a real robot's
    is plain text. (message, reason, whether it was ours)."""
    try:
        data = json.loads(text)
    except (ValueError, TypeError):
        return text, "", False
    if isinstance(data, dict) and "message" in data:
        return str(data["message"]), str(data.get("reason") or ""), True
    return text, "", False


__all__ = ["ACTIONS", "REQUIRED", "RobotUnavailableError", "RosRobot", "Timeouts"]
