"""The robot and its perception over ROS 2: every skill the executor calls is an action goal.

:class:`RosRobot` is an :class:`~llmpas.execution.robot_protocols.Robot` and a
:class:`~llmpas.execution.robot_protocols.Perception` whose calls become goals of the robot's action
servers (names in :mod:`llmpas.worlds.ros2.names`): the base is Nav2's ``NavigateToPose``, the
arm's named configuration (home) ros2_control's ``FollowJointTrajectory``, the rest the project's
``Skill`` and ``Look`` actions. A skill sends its goal and returns a :class:`RosGoal`, the
executor's handle: each tick polls it (the node's executor spins in its own thread, so feedback
and topics keep arriving) and a preempted skill cancels the goal on the robot. A rejected goal,
an abort or a timeout is a skill failure with that reason, which the subtree explores like any
other; a server that vanished (its node killed) is :class:`~llmpas.errors.RobotLostError`,
which ends the run naming the server and the domain.

After every goal the robot's state (odometry, the held object, the planning scene) is read with
the ``scene_state`` service; the planning scene is the one the streams reason on.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from llmpas.errors import RobotLostError
from llmpas.execution.robot_protocols import Observation, Outcome, SkillResult, finish
from llmpas.worlds.pybullet.pybullet_values import ArmGoal, BaseConf, ObjectPose
from llmpas.worlds.pybullet.scene import Scene
from llmpas.worlds.ros2 import convert
from llmpas.worlds.ros2.names import ACTIONS, FJT, GRIPPER, LOOK, NAV, SKILL, STATE, action_names
from llmpas.worlds.ros2.profile import RobotProfile
from llmpas.worlds.ros2.spin import Spinner

log = logging.getLogger(__name__)


T = TypeVar("T")

REQUIRED = (NAV, FJT, SKILL, LOOK)  # what the loop calls (the gripper action is optional)


class RobotUnavailableError(Exception):
    """An action server or service of the robot did not appear in time (names it)."""


class RosGoal:
    """One action goal as the executor's skill handle: sent when made, then ``poll()`` (never
    blocks) until it ends, ``cancel()`` asks the server to cancel it.

    The goal ends as a failure when it is not accepted within ``timeouts.accept`` (reason
    ``lost``), rejected (``rejected``), aborted or cancelled by the server, or runs past
    ``timeouts.goal`` (it is cancelled: ``timeout``). A server that is gone from the graph for
    ``timeouts.lost`` seconds raises :class:`~llmpas.errors.RobotLostError`.
    ``done`` turns the action's result into the success's message."""

    def __init__(
        self, robot: RosRobot, name: str, goal: Any, done: Callable[[Any], SkillResult]
    ) -> None:
        self.robot, self.name, self.done = robot, name, done
        self.client = robot.clients[name]
        self.final: SkillResult | None = None
        self.raw: Any = None  # the action's result, once it came
        self.accepted: Any = None  # rclpy's ClientGoalHandle
        self.result_future: Any = None
        self.gone: float | None = None
        if not self.client.server_is_ready() and not self.client.wait_for_server(
            timeout_sec=robot.timeouts.lost
        ):
            raise robot.lost_error(name, "is gone")
        robot.goals += 1
        robot.on_goal(f"/{name}/goal", "Goal", goal)
        self.sent = robot.request(
            lambda: self.client.send_goal_async(
                goal,
                feedback_callback=lambda f: robot.on_goal(
                    f"/{name}/feedback", "Feedback", f.feedback
                ),
            )
        )
        self.deadline = time.monotonic() + robot.timeouts.accept

    def poll(self) -> SkillResult:
        if self.final is not None:
            return self.final
        now = time.monotonic()
        if self.accepted is None:
            if not self.sent.done():
                if now > self.deadline:
                    return self._end(
                        SkillResult.failure(f"/{self.name} did not answer the goal", reason="lost")
                    )
                self._check_server(now)
                return SkillResult.still_running(f"/{self.name}: goal sent")
            handle = self.sent.result()
            if not handle.accepted:
                return self._end(
                    SkillResult.failure(f"/{self.name} rejected the goal", reason="rejected")
                )
            self.accepted, self.result_future = handle, self.robot.request(handle.get_result_async)
            self.deadline = now + self.robot.timeouts.goal
        if not self.result_future.done():
            if now > self.deadline:
                self._cancel_on_robot()
                return self._end(SkillResult.failure(f"/{self.name} timed out", reason="timeout"))
            self._check_server(now)
            return SkillResult.still_running(f"/{self.name}: goal running")
        return self._end(self._outcome(self.result_future.result()))

    def cancel(self) -> None:
        """Cancel the goal on the robot (waits up to 2 s for the server's answer)."""
        if self.final is not None:
            return
        if self.accepted is None and self.robot.wait(self.sent, 2.0):
            handle = self.sent.result()
            self.accepted = handle if handle.accepted else None
        if self.accepted is not None:
            log.info("cancelling the /%s goal on the robot", self.name)
            self._cancel_on_robot()
        self._end(SkillResult.failure(f"/{self.name}: goal cancelled", reason="cancelled"))

    def _cancel_on_robot(self) -> None:
        self.robot.wait(self.robot.request(self.accepted.cancel_goal_async), 2.0)

    def _check_server(self, now: float) -> None:
        """RobotLostError when the server has been gone for ``timeouts.lost`` seconds."""
        if self.client.server_is_ready():
            self.gone = None
        elif self.gone is None:
            self.gone = now
        elif now - self.gone > self.robot.timeouts.lost:
            self.final = SkillResult.failure(f"the /{self.name} server vanished", reason="lost")
            raise self.robot.lost_error(self.name, "vanished during a goal")

    def _outcome(self, wrapped: Any) -> SkillResult:
        from action_msgs.msg import GoalStatus

        self.raw = wrapped.result
        self.robot.on_goal(f"/{self.name}/result", "Result", wrapped.result)
        self.robot.sync()
        if wrapped.status == GoalStatus.STATUS_SUCCEEDED:
            return self.done(wrapped.result)
        what = {GoalStatus.STATUS_ABORTED: "aborted", GoalStatus.STATUS_CANCELED: "canceled"}
        return _failure(wrapped.result, what.get(wrapped.status, "failed"))

    def _end(self, result: SkillResult) -> SkillResult:
        self.final = result
        return result


@dataclass(frozen=True)
class Timeouts:
    """Seconds: to find every server at start, for a goal to be accepted, for a goal to end,
    and for a server that vanished mid-goal to come back."""

    discover: float = 30.0
    accept: float = 30.0
    goal: float = 300.0
    lost: float = 3.0
    settle: float = 1.0  # for joint states stamped after a goal's result (a standard robot)
    cancel: float = 2.0  # for the reply to a cancel (waited for off the tick's thread)


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
        self.spinner = Spinner(self.node, context)  # requests and replies under one lock
        self.believed: tuple[float, float, float] = scene.config.base
        self.log: list[str] = []
        self.frames: list[Any] = []  # the run folder's media: none (the robot keeps its own)
        self.images: list[Any] = []
        self.clock: Callable[[], tuple[int, int]] = lambda: (0, 0)
        self.goals = 0

    def request(self, send: Callable[[], T]) -> T:
        """``send()`` (a goal, result, cancel or service request) while no reply is taken."""
        return self.spinner.request(send)

    def shutdown(self) -> None:
        """Stop spinning; the node goes with its context (never blocks on a busy spinner)."""
        self.spinner.shutdown()

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
        future = self.request(lambda: self.state_client.call_async(GetSceneState.Request()))
        if not self.wait(future, self.timeouts.accept):
            self.state_client.remove_pending_request(future)
            return False
        self.believed = convert.apply_state(self.scene, future.result().state)
        return True

    def wait(self, future: Any, seconds: float) -> bool:
        """Whether ``future`` is done within ``seconds`` (the spinner thread completes it)."""
        return self.spinner.wait(future, seconds)

    def lost_error(self, name: str, what: str) -> RobotLostError:
        kind = self.types[name]
        return RobotLostError(
            f"the robot's ROS 2 action server /{name} ({kind.__module__.split('.')[0]}/"
            f"{kind.__name__}) {what}; ROS_DOMAIN_ID={self.node.context.get_domain_id()}"
        )

    # ------------------------------------------------------------------ goals

    def send(
        self, name: str, goal: Any, done: Callable[[Any], SkillResult] | None = None
    ) -> RosGoal:
        """Send ``goal`` to ``/name``: its handle (``done``: the success's result, from the
        action's result; default a plain success)."""
        return RosGoal(self, name, goal, done or (lambda raw: SkillResult.success()))

    def goal(self, name: str, goal: Any) -> tuple[SkillResult | None, Any]:
        """Send ``goal`` to ``/name`` and wait for its end (perception, tests): (None, result)
        when it succeeded; (failure, result or None) otherwise."""
        handle = self.send(name, goal)
        outcome = finish(handle)
        return (None if outcome.ok else outcome), handle.raw

    # ------------------------------------------------------------------ Robot

    def base_conf(self) -> BaseConf:
        x, y, t = self.believed
        return BaseConf(x, y, t)

    def holding(self) -> str | None:
        return self.scene.held

    def move_base(self, conf: Any) -> Outcome:
        if not isinstance(conf, BaseConf):
            return SkillResult.failure(f"not a base configuration: {conf!r}", reason="bad_value")
        goal = self.types[NAV].Goal()
        goal.pose = convert.pose_stamped(conf.x, conf.y, 0.0, conf.theta)
        return self.send(NAV, goal, lambda raw: _success(raw.error_msg))

    def move_arm(self, target: Any) -> Outcome:
        if isinstance(target, str) and target == "home":
            return self._joints(self.profile.arm.home)
        if not isinstance(target, ArmGoal):
            return SkillResult.failure(f"not an arm goal: {target!r}", reason="bad_value")
        return self._skill("move_arm", convert.arm_goal_json(target))

    def _joints(self, q: tuple[float, ...]) -> Outcome:
        from trajectory_msgs.msg import JointTrajectoryPoint

        goal = self.types[FJT].Goal()
        goal.trajectory.header.frame_id = "base_link"
        goal.trajectory.joint_names = list(self.profile.arm.joints)
        point = JointTrajectoryPoint()
        point.positions = [float(v) for v in q]
        point.time_from_start.sec = 3
        goal.trajectory.points = [point]
        return self.send(FJT, goal, lambda raw: _success(raw.error_string))

    def _skill(self, skill: str, args: str) -> Outcome:
        goal = self.types[SKILL].Goal()
        goal.skill, goal.args = skill, args
        return self.send(SKILL, goal, lambda raw: SkillResult.success(raw.message))

    def grasp(self, obj: str, grasp: Any) -> Outcome:
        return self._skill("grasp", json.dumps({"obj": obj, "grasp": grasp.kind}))

    def release(self, obj: str, pose: Any) -> Outcome:
        if not isinstance(pose, ObjectPose):
            return SkillResult.failure(f"not a pose: {pose!r}", reason="bad_value")
        spot = [pose.region, pose.x, pose.y, pose.z]
        return self._skill("release", json.dumps({"obj": obj, "pose": spot}))

    def open(self, container: str) -> Outcome:
        return self._skill("open", json.dumps({"container": container}))

    def close(self, container: str) -> Outcome:
        return self._skill("close", json.dumps({"container": container}))

    def process(self, obj: str, appliance: str, how: str) -> Outcome:
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


__all__ = ["ACTIONS", "REQUIRED", "RobotUnavailableError", "RosGoal", "RosRobot", "Timeouts"]
