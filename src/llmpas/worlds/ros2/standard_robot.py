"""A robot that speaks only standard ROS 2, driven by llmpas (``interfaces: standard``).

The base is Nav2's ``NavigateToPose`` (its ``error_code`` is the failure's reason), the arm
ros2_control's ``FollowJointTrajectory`` with trajectories llmpas plans itself, the hand
``GripperCommand``; the robot's pose is TF's ``map -> base_link`` (:mod:`llmpas.worlds.ros2.tf`),
its arm ``joint_states``, what it sees a detector's ``vision_msgs/Detection3DArray`` (poses in
their own frames, resolved through TF at their stamps). The planning scene is llmpas's own
(:class:`~llmpas.worlds.pybullet.scene.Scene`): the scenario's static geometry and the profile's
furniture, the robot's kinematics checked against ``robot_description`` (joint names and
limits), kept up to date from TF, ``joint_states``, the detections and the gripper's results.

Every skill returns a :class:`Steps`, the executor's handle: a list of steps, each of which
sends one goal (or ends the skill); ``poll()`` advances it without blocking (RUNNING until it
ends) and ``cancel()`` cancels the goal under way, so that the tree ticks while the robot moves.
Perception polls its steps to their end (:meth:`StandardRobot.run`). A server that vanishes is
:class:`~llmpas.errors.RobotLostError` (the run ends naming it and the domain).
"""

from __future__ import annotations

import logging
import math
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any, TypeVar

import numpy as np

from llmpas.errors import RobotLostError
from llmpas.execution.robot_protocols import Detection, Observation, SkillResult
from llmpas.worlds.pybullet.camera import RIM_MARGIN
from llmpas.worlds.pybullet.pybullet_robot import goal_height, look_orientation, near_graspable
from llmpas.worlds.pybullet.pybullet_values import ArmGoal, BaseConf, ObjectPose
from llmpas.worlds.pybullet.scene import TABLE_TOP, Scene
from llmpas.worlds.pybullet.skills import Skills
from llmpas.worlds.ros2 import convert
from llmpas.worlds.ros2.client import RobotUnavailableError, Timeouts
from llmpas.worlds.ros2.goal_polling import Later, Send, Step, Steps, stamp_seconds
from llmpas.worlds.ros2.names import FJT, GRIPPER, NAV, STANDARD, action_names
from llmpas.worlds.ros2.nav2 import nav2_reason
from llmpas.worlds.ros2.profile import CAMERAS, Place, RobotProfile
from llmpas.worlds.ros2.spin import Spinner
from llmpas.worlds.ros2.tf import TfBuffer, TfError, Transform

log = logging.getLogger(__name__)


T = TypeVar("T")


class RecordingSkills(Skills):
    """The PyBullet skills on the planning scene, their arm paths kept to be sent as
    trajectories (the planning scene's arm moves along, kinematically)."""

    def __init__(self, scene: Scene, rng: np.random.Generator) -> None:
        super().__init__(scene, rng)
        self.paths: list[list[tuple[float, ...]]] = []

    def follow(self, path: Any) -> None:
        points = [tuple(float(v) for v in q) for q in path]
        if points:
            self.paths.append(points)
        for q in points:
            self.scene.set_arm(q)
            self.scene.carry()
        self.scene.carry()


class StandardRobot:
    """Skills and perception of a standard ROS 2 robot (an rclpy node in its own context)."""

    def __init__(
        self,
        context: Any,
        scene: Scene | None,
        profile: RobotProfile,
        rng: np.random.Generator,
        timeouts: Timeouts | None = None,
        on_goal: Callable[[str, str, Any], None] | None = None,
        build_scene: Callable[[str, tuple[float, float, float]], Scene] | None = None,
    ) -> None:
        """``scene``: the planning scene; None: ``build_scene(description, base)`` makes it
        once the robot's description and its pose in the map have come."""
        import rclpy
        from control_msgs.action import FollowJointTrajectory, GripperCommand
        from nav2_msgs.action import NavigateToPose
        from rclpy.action import ActionClient
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String
        from tf2_msgs.msg import TFMessage
        from vision_msgs.msg import Detection3DArray

        if scene is None and build_scene is None:
            raise ValueError("a planning scene or a way to build one")
        self.build_scene = build_scene
        self.rng = rng
        self.profile = profile
        self.timeouts = timeouts or Timeouts()
        self.on_goal = on_goal or (lambda channel, kind, msg: None)
        from rclpy.parameter import Parameter

        sim_time = [Parameter("use_sim_time", Parameter.Type.BOOL, True)]
        self.node = rclpy.create_node(
            "llmpas_client",
            context=context,
            namespace=profile.namespace or None,
            parameter_overrides=sim_time if profile.use_sim_time else [],
        )
        self.types = {NAV: NavigateToPose, FJT: FollowJointTrajectory, GRIPPER: GripperCommand}
        self.clients = {
            k: ActionClient(self.node, t, action_names(profile)[k]) for k, t in self.types.items()
        }
        self.names = {k: self.node.resolve_topic_name(action_names(profile)[k]) for k in self.types}
        self.tf = TfBuffer()
        self.lock = threading.Lock()
        self.joints: dict[str, float] = {}
        self.joints_stamp = 0.0  # the last joint_states' stamp (the robot's clock)
        self.stamp = 0.0  # the latest stamp of anything the robot sent (its clock)
        self.scene_lock = threading.RLock()  # the planning scene: planning vs. the tick
        self.planning = 0  # trajectories being planned off the tick's thread
        self.polls_planning = 0  # polls answered RUNNING while a trajectory was planned
        self.polls_accepting = 0  # ... while a goal waited to be accepted
        self.cancels = 0  # cancel requests sent
        self.description = ""
        self.detections: dict[str, tuple[float, Any]] = {}  # topic key -> (arrival, msg)
        t = profile.topics
        sub = self.node.create_subscription
        self.subscriptions = [
            sub(TFMessage, t.tf.name, lambda m: self._tf(m, False), t.tf.qos.rclpy()),
            sub(TFMessage, t.tf_static.name, lambda m: self._tf(m, True), t.tf_static.qos.rclpy()),
            sub(JointState, t.joint_states.name, self._joint_states, t.joint_states.qos.rclpy()),
            sub(String, t.robot_description.name, self._description,
                t.robot_description.qos.rclpy()),
        ]  # fmt: skip
        for key in {look.detections for look in profile.looks}:
            topic = getattr(t, key)
            self.subscriptions.append(
                sub(Detection3DArray, topic.name, self._detector(key), topic.qos.rclpy())
            )
        self.spinner = Spinner(self.node, context)  # requests and replies under one lock
        self.scene: Scene = scene  # type: ignore[assignment]  # built at connection if None
        # built at connection with the scene if None
        self.skills: RecordingSkills = RecordingSkills(scene, rng) if scene else None  # type: ignore[assignment]
        self.believed: tuple[float, float, float] = (
            scene.config.base if scene is not None else (0.0, 0.0, 0.0)
        )
        self.log: list[str] = []
        self.frames: list[Any] = []
        self.images: list[Any] = []
        self.clock: Callable[[], tuple[int, int]] = lambda: (0, 0)
        self.goals = 0
        # per camera, the robot's latest stamp when the last goal that changed its view was
        # sent (detections stamped before are stale): the base or the hand (objects move)
        # changes both, the arm the wrist's. Stamps are compared with stamps, never with this
        # process's clock (simulated time, a clock offset between machines)
        self.moved_at = {camera: 0.0 for camera in CAMERAS}
        self.places: tuple[Place, ...] = ()  # the profile's, in map (once TF has them)
        # an object detected that the planning scene does not hold: (class id, where, size)
        # -> whether it was added to the scene (None: such detections are ignored)
        self.discover: (
            Callable[[str, tuple[float, float, float], tuple[float, float, float]], bool] | None
        ) = None

    # ------------------------------------------------------------------ the graph

    def request(self, send: Callable[[], T]) -> T:
        """``send()`` (a goal, result or cancel request) while no reply is being taken."""
        return self.spinner.request(send)

    def shutdown(self) -> None:
        self.spinner.shutdown()

    def _tf(self, msg: Any, static: bool) -> None:
        for t in msg.transforms:
            tr, r = t.transform.translation, t.transform.rotation
            try:
                value = Transform((tr.x, tr.y, tr.z), (r.x, r.y, r.z, r.w))
                stamp = stamp_seconds(t.header.stamp)
                self.tf.add(t.header.frame_id, t.child_frame_id, stamp, value, static)
                if not static:
                    self.stamp = max(self.stamp, stamp)
            except ValueError as e:
                log.warning("ignoring a transform %s -> %s: %s", t.header.frame_id,
                            t.child_frame_id, e)  # fmt: skip

    def _joint_states(self, msg: Any) -> None:
        with self.lock:
            for name, q in zip(msg.name, msg.position, strict=False):
                self.joints[name] = float(q)
            self.joints_stamp = stamp_seconds(msg.header.stamp)
            self.stamp = max(self.stamp, self.joints_stamp)

    def _description(self, msg: Any) -> None:
        self.description = str(msg.data)

    def _detector(self, key: str) -> Callable[[Any], None]:
        def got(msg: Any) -> None:
            with self.lock:
                self.detections[key] = (time.monotonic(), msg)

        return got

    def wait(self, future: Any, seconds: float) -> bool:
        return self.spinner.wait(future, seconds)

    # ------------------------------------------------------------------ connection

    def wait_for_servers(self) -> None:
        """The three action servers, the robot's description (its arm joints checked), its
        joint states and ``map -> base_link``, within ``timeouts.discover``."""
        deadline = time.monotonic() + self.timeouts.discover
        for key in STANDARD:
            left = max(0.0, deadline - time.monotonic())
            if not self.clients[key].wait_for_server(timeout_sec=left):
                kind = self.types[key]
                raise RobotUnavailableError(
                    f"no ROS 2 action server {self.names[key]} ({kind.__module__.split('.')[0]}"
                    f"/{kind.__name__}) within {self.timeouts.discover:g} s"
                )
        t, f = self.profile.topics, self.profile.frames
        needs: list[tuple[str, Callable[[], bool]]] = [
            (f"the topic {t.robot_description.name} (std_msgs/String, the URDF)",
             lambda: bool(self.description)),
            (f"the topic {t.joint_states.name} with the arm's joints",
             lambda: all(j in self.joints for j in self.profile.arm.joints)),
            (f"the transform {f.map} -> {f.base} on {t.tf.name}", self._has_base),
        ]  # fmt: skip
        for what, ready in needs:
            while not ready():
                if time.monotonic() > deadline:
                    raise RobotUnavailableError(f"no {what} within {self.timeouts.discover:g} s")
                time.sleep(0.02)
        self._check_description()
        if self.build_scene is not None and self.scene is None:
            base = self.tf.lookup(f.map, f.base)
            x, y, _ = base.translation
            self.scene = self.build_scene(self.description, (x, y, base.yaw))
            self.skills = RecordingSkills(self.scene, self.rng)
        self._static_geometry()
        self.sync()

    def _in_map(self, frame: str) -> Transform:
        try:
            return self.tf.lookup(self.profile.frames.map, frame)
        except TfError as e:
            raise RobotUnavailableError(f"the profile's frame {frame}: {e}") from None

    def _static_geometry(self) -> None:
        """The profile's places (footprints) and furniture (boxes) in ``map``; the furniture
        joins the planning scene as obstacles."""
        import pybullet as p

        places = []
        for place in self.profile.places:
            to_map = self._in_map(place.frame)
            points = tuple(to_map.apply((x, y, 0.0))[:2] for x, y in place.footprint)
            places.append(replace(place, frame=self.profile.frames.map, footprint=points))
        self.places = tuple(places)
        c = self.scene.client
        for item in self.profile.furniture:
            if item.name in self.scene.bodies:
                continue  # the scenario has it already
            x, y, z, yaw = item.pose
            at = self._in_map(item.frame) * Transform.planar(x, y, yaw, z)
            half = [v / 2 for v in item.size]
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
            body = p.createMultiBody(0, shape, -1, list(at.translation), list(at.rotation),
                                     physicsClientId=c)  # fmt: skip
            self.scene.bodies[item.name] = int(body)

    def _has_base(self) -> bool:
        try:
            self.tf.lookup(self.profile.frames.map, self.profile.frames.base)
        except TfError:
            return False
        return True

    def _check_description(self) -> None:
        """The profile's arm joints are the URDF's (revolute, with limits that hold home)."""
        try:
            root = ET.fromstring(self.description)
        except ET.ParseError as e:
            raise RobotUnavailableError(f"robot_description is not URDF: {e}") from None
        joints = {j.get("name"): j for j in root.iter("joint")}
        for name, home in zip(self.profile.arm.joints, self.profile.arm.home, strict=True):
            joint = joints.get(name)
            if joint is None:
                raise RobotUnavailableError(f"robot_description has no joint {name!r}")
            limit = joint.find("limit")
            if limit is not None and joint.get("type") == "revolute":
                lo, hi = float(limit.get("lower", "-inf")), float(limit.get("upper", "inf"))
                if not lo - 1e-6 <= home <= hi + 1e-6:
                    raise RobotUnavailableError(
                        f"the profile's home position of {name} ({home}) is outside the URDF's "
                        f"limits [{lo}, {hi}]"
                    )

    def latest_stamp(self) -> float:
        """The latest stamp of anything the robot sent (TF, joint states): its clock, now."""
        return self.stamp

    def sync(self) -> None:
        """The planning scene's base from TF and its arm from joint_states."""
        with self.scene_lock:
            self._sync()

    def _sync(self) -> None:
        f = self.profile.frames
        try:
            base = self.tf.lookup(f.map, f.base)
        except TfError as e:
            log.warning("no base pose from TF: %s", e)
        else:
            x, y, _ = base.translation
            self.believed = (x, y, base.yaw)
            self.scene.set_base(x, y, base.yaw)
        with self.lock:
            q = [self.joints.get(j) for j in self.profile.arm.joints]
        if all(v is not None for v in q):
            self.scene.set_arm([float(v) for v in q if v is not None])
        self.scene.carry()

    def failure(self, action: str, wrapped: Any) -> SkillResult:
        from action_msgs.msg import GoalStatus

        raw = wrapped.result
        status = {GoalStatus.STATUS_ABORTED: "aborted", GoalStatus.STATUS_CANCELED: "canceled"}
        what = status.get(wrapped.status, "failed")
        if action == NAV:
            code = int(raw.error_code)
            reason = nav2_reason(code) if wrapped.status == GoalStatus.STATUS_ABORTED else what
            text = raw.error_msg or f"navigation {what}"
            return SkillResult.failure(text, reason=reason, error_code=code)
        if action == FJT:
            return SkillResult.failure(
                raw.error_string or f"trajectory {what}",
                reason=what,
                error_code=int(raw.error_code),
            )
        return SkillResult.failure(f"gripper {what}", reason=what)

    # ------------------------------------------------------------------ running skills

    def lost_error(self, action: str, what: str) -> RobotLostError:
        kind = self.types[action]
        return RobotLostError(
            f"the robot's ROS 2 action server {self.names[action]} "
            f"({kind.__module__.split('.')[0]}/{kind.__name__}) {what}; "
            f"ROS_DOMAIN_ID={self.node.context.get_domain_id()}"
        )

    def run(self, steps: Steps) -> SkillResult:
        """Poll steps to their end (perception; Ctrl-C cancels the goal on the robot first)."""
        try:
            while True:
                result = steps.poll()
                if not result.running:
                    return result
                time.sleep(0.002)
        except KeyboardInterrupt:
            steps.cancel()
            raise

    def _trajectory(self, path: list[tuple[float, ...]]) -> Send:
        from trajectory_msgs.msg import JointTrajectoryPoint

        arm = self.profile.arm
        goal = self.types[FJT].Goal()
        goal.trajectory.header.frame_id = self.profile.frames.base
        goal.trajectory.joint_names = list(arm.joints)
        for k, q in enumerate(path, start=1):
            point = JointTrajectoryPoint()
            point.positions = [float(v) for v in q]
            t = k * arm.seconds_per_point
            point.time_from_start.sec = int(t)
            point.time_from_start.nanosec = int((t - int(t)) * 1e9)
            goal.trajectory.points.append(point)
        return Send(FJT, goal)

    def _plan(self, plan: Callable[[], bool], failure: SkillResult) -> Step:
        """A step that plans an arm motion on the planning scene and sends its trajectory."""

        def step() -> Send | SkillResult:
            self.sync()
            self.skills.paths.clear()
            if not plan():
                self.sync()  # the planning scene's arm back where the robot's is
                return failure
            path = [q for p in self.skills.paths for q in p]
            self.sync()
            if not path:
                return SkillResult.success()  # already there
            return self._trajectory(path)

        def wrapped() -> Send | SkillResult | None:
            out = step()
            return out if isinstance(out, Send) or not out.ok else None

        return lambda: Later(self, wrapped)  # planned off the tick's thread

    def _gripper(self, position: float, effort: float, check: Callable[[Any], Any]) -> Step:
        def step() -> Send:
            goal = self.types[GRIPPER].Goal()
            goal.command.position, goal.command.max_effort = float(position), float(effort)
            return Send(GRIPPER, goal, check)

        return step

    # ------------------------------------------------------------------ Robot

    def base_conf(self) -> BaseConf:
        x, y, t = self.believed
        return BaseConf(x, y, t)

    def holding(self) -> str | None:
        return self.scene.held

    def move_base(self, conf: Any) -> Steps | SkillResult:
        if not isinstance(conf, BaseConf):
            return SkillResult.failure(f"not a base configuration: {conf!r}", reason="bad_value")
        goal = self.types[NAV].Goal()
        goal.pose = convert.pose_stamped(conf.x, conf.y, 0.0, conf.theta)
        goal.pose.header.frame_id = self.profile.frames.map
        done = SkillResult.success(f"drove to {conf}")
        return Steps(self, [lambda: Send(NAV, goal)], done)

    def home(self) -> Step:
        return self._plan(self.skills.home, SkillResult.failure("cannot fold"))

    def move_arm(self, target: Any) -> Steps | SkillResult:
        if isinstance(target, str) and target == "home":
            return Steps(self, [self.home()], SkillResult.success("arm folded"))
        if not isinstance(target, ArmGoal):
            return SkillResult.failure(f"not an arm goal: {target!r}", reason="bad_value")
        pose, kind = target.pose, target.grasp.kind
        height = goal_height(self.scene, target)
        if target.phase == "pre":
            ignore = () if self.scene.held else tuple(near_graspable(self.scene, pose))
            what = "pre-approach"

            def plan() -> bool:
                return self.skills.pre_approach(pose, kind, height, ignore=ignore)
        else:
            what = "approach"

            def plan() -> bool:
                return self.skills.approach(pose, kind, height)

        failed = SkillResult.failure(f"{what} to {target.pose} failed", reason="unreachable")
        done = SkillResult.success(f"{what} {target.pose}")
        return Steps(self, [self._plan(plan, failed)], done)

    def grasp(self, obj: str, grasp: Any) -> Steps | SkillResult:
        """Close the hand (held when the fingers stall on something), lift, fold; a miss opens
        the hand again, lifts and folds, and fails (reason ``nothing``)."""
        if self.scene.held is not None:
            return SkillResult.failure("the hand is full", reason="hand_full")
        arm = self.profile.arm
        lift = self._plan(self.skills.lift, SkillResult.failure("cannot lift"))
        steps = Steps(self, [], SkillResult.success(f"holding {obj}"))

        def closed(raw: Any) -> None:
            if raw.stalled:  # the fingers stopped on something: what the hand is at
                ee, _ = self.scene.ee_pose()
                self.scene.set_pose(obj, (float(ee[0]), float(ee[1]), float(ee[2])))
                self.scene.attach(obj)
                steps.steps[:0] = [lift, self.home()]
            else:
                opened = self._gripper(arm.gripper_open, 0.0, lambda raw: None)
                steps.steps[:0] = [opened, lift, self.home()]
                steps.done = SkillResult.failure(f"missed {obj}", reason="nothing")

        steps.steps = [self._gripper(0.0, arm.max_effort, closed)]
        return steps

    def release(self, obj: str, pose: Any) -> Steps | SkillResult:
        if self.scene.held != obj:
            return SkillResult.failure(f"not holding {obj}", reason="not_held")

        def opened(raw: Any) -> None:
            self.scene.detach()
            self.scene.settle(120)  # the planning scene's object drops where it was let go

        return Steps(
            self,
            [self._gripper(self.profile.arm.gripper_open, 0.0, opened),
             self._plan(self.skills.lift, SkillResult.failure("cannot lift")), self.home()],
            SkillResult.success(f"released {obj}"),
        )  # fmt: skip

    def open(self, container: str) -> SkillResult:
        return SkillResult.failure(f"{container} cannot be opened", reason="not_openable")

    def close(self, container: str) -> SkillResult:
        return SkillResult.failure(f"{container} cannot be closed", reason="not_openable")

    def process(self, obj: str, appliance: str, how: str) -> SkillResult:
        return SkillResult.failure(f"no {how} here", reason="cannot_process")

    def snapshot(self, label: str) -> None:
        """Images stay with the robot."""

    # ------------------------------------------------------------------ Perception

    def moved(self, action: str) -> None:
        now = self.latest_stamp()
        for camera in self.moved_at:
            if action != FJT or camera != "mast":
                self.moved_at[camera] = now

    def _fresh(self, camera: str) -> Any | None:
        """The latest detections of ``camera``'s topic taken since the last goal that changed
        its view was sent (the robot's motion since is in them), else the next one, within the
        look's wait."""
        look = self.profile.look(camera)
        end = time.monotonic() + look.wait
        while time.monotonic() < end:
            with self.lock:
                got = self.detections.get(look.detections)
            if got is not None and stamp_seconds(got[1].header.stamp) > self.moved_at[camera]:
                return got[1]
            time.sleep(0.01)
        log.warning("no fresh detections on %s within %g s", look.detections, look.wait)
        return None

    def observation(self, msg: Any) -> Observation:
        with self.scene_lock:
            return self._observation(msg)

    def _observation(self, msg: Any) -> Observation:
        """A Detection3DArray as an observation in ``map``: poses through TF at the message's
        stamp; a place's class id is a place in view; the region of an object from the
        places' footprints (a bowl's inside when it is in one)."""
        frame = msg.header.frame_id
        try:
            to_map = self.tf.lookup(self.profile.frames.map, frame, stamp_seconds(msg.header.stamp))
        except TfError as e:
            log.warning("detections in %s dropped: %s", frame, e)
            return Observation(())
        places = set(self.scene.tables) | {p.name for p in self.places}
        known = {o.name: o for o in self.scene.config.objects}
        viewed: set[str] = set()
        seen: dict[str, tuple[tuple[float, float, float], float]] = {}
        for d in msg.detections:
            if not d.results:
                continue
            best = max(d.results, key=lambda h: h.hypothesis.score)
            name = str(best.hypothesis.class_id)
            if name in places:
                viewed.add(name)
                continue
            pos = best.pose.pose.position
            x, y, z = to_map.apply((pos.x, pos.y, pos.z))
            at = (round(x, 4), round(y, 4), round(z, 4))
            if name not in known:  # neither told of nor seen before: the session may add it
                size = (float(d.bbox.size.x), float(d.bbox.size.y), float(d.bbox.size.z))
                if self.discover is None or not self.discover(name, at, size):
                    continue
                known = {o.name: o for o in self.scene.config.objects}
            seen[name] = (at, float(best.hypothesis.score))
        bowls = {n: at for n, (at, _) in seen.items() if known[n].kind == "bowl"}
        viewed |= set(bowls)
        dets = []
        for name, (at, score) in sorted(seen.items()):
            region = self._region(name, at, bowls) or "unknown"
            pose = ObjectPose(region, *at)
            dets.append(Detection(name, region, pose, min(1.0, max(0.0, score))))
            if name != self.scene.held:
                self.scene.set_pose(name, at)
        return Observation(tuple(sorted(viewed)), tuple(dets))

    def _region(
        self, name: str, at: tuple[float, float, float], bowls: Mapping[str, tuple[float, ...]]
    ) -> str | None:
        o = self.scene.config.obj(name)
        bottom = at[2] - o.origin_height
        for b, bat in bowls.items():
            bowl = self.scene.config.obj(b)
            half = bowl.size / 2
            inside = abs(at[0] - bat[0]) <= half and abs(at[1] - bat[1]) <= half
            if b != name and inside and bottom < bat[2] + bowl.height - RIM_MARGIN:
                return b
        for place in self.places:
            if place.contains(at[0], at[1]):
                return place.name
        for t, rect in self.scene.tables.items():
            if rect.contains(at[0], at[1]):
                return t
        return None

    def look(self, target: str | None = None) -> Observation:
        msg = self._fresh("mast")
        return Observation(()) if msg is None else self.observation(msg)

    def look_with_arm(self, target: str | None = None) -> Observation:
        """The wrist camera raised above the near edge of the place (the profile's joints to
        look from, else a pose planned like the in-process robot's), then folded again."""
        look = self.profile.look("arm")
        bx, by, bt = self.believed
        if target is not None and target in self.scene.tables:
            cx, cy = self.scene.tables[target].center
            point = np.array([cx, cy, TABLE_TOP])
        else:
            point = np.array([bx + math.cos(bt), by + math.sin(bt), TABLE_TOP])
        eye = np.array([bx, by, 1.05]) + np.array([math.cos(bt), math.sin(bt), 0.0]) * 0.55
        if look.joints:
            goal_q: tuple[float, ...] | None = tuple(look.joints)
        else:
            goal_q = self.skills.solve(eye, look_orientation(point - eye))
        if goal_q is None:
            return self.look(target)
        q = goal_q
        moved = self.run(
            Steps(self, [self._plan(lambda: self.skills.move_arm(q), SkillResult.failure(""))],
                  SkillResult.success())
        )  # fmt: skip
        if not moved.ok:
            return self.look(target)
        msg = self._fresh("arm")
        obs = Observation(()) if msg is None else self.observation(msg)
        self.run(Steps(self, [self.home()], SkillResult.success()))
        return obs

    def wrist_detect(self, obj: str) -> ObjectPose | None:
        msg = self._fresh("wrist")
        if msg is None:
            return None
        d = self.observation(msg).find(obj)
        return d.pose if d is not None and isinstance(d.pose, ObjectPose) else None


__all__ = ["RecordingSkills", "Send", "StandardRobot", "Steps"]
