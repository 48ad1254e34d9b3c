"""The PyBullet Husky + Panda as a ROS 2 robot, in a process of its own.

It serves, from the simulator (:class:`~llmpas.worlds.pybullet.pybullet_robot.PyBulletWorld`,
seeded as
in-process):

- ``navigate_to_pose`` (``nav2_msgs/action/NavigateToPose``): drive the base (a collision-free
  path is planned on the robot);
- ``arm_controller/follow_joint_trajectory`` (``control_msgs/action/FollowJointTrajectory``):
  the arm to the trajectory's last point (collision-free);
- ``gripper_controller/gripper_cmd`` (``control_msgs/action/GripperCommand``): open, or close
  on what is between the fingers;
- ``llmpas/skill`` (``llmpas_interfaces/action/Skill``): move_arm to a grasp, grasp, release,
  open, close, process;
- ``llmpas/look`` (``llmpas_interfaces/action/Look``): the mast, arm or wrist camera's detections;
- ``llmpas/scene_state`` (``llmpas_interfaces/srv/GetSceneState``): the planning scene (every
  body, the held object, odometry);

and publishes ``odom`` (``nav_msgs/Odometry``, the believed pose), ``joint_states``,
``detections`` and ``scene_markers`` (``visualization_msgs/MarkerArray``) after every goal.

Faults for tests (``--reject``, ``--abort``, ``--stall`` a kind: ``navigate_to_pose``,
``follow_joint_trajectory``, ``look`` or a skill's name) make a server reject a goal, abort it,
or hold it until it is cancelled.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.robot_protocols import Detection, Observation, SkillResult
from llmpas.worlds.pybullet.pybullet_robot import PyBulletWorld
from llmpas.worlds.pybullet.pybullet_scenarios import PyBulletScenario, resolve, setup_scene
from llmpas.worlds.pybullet.pybullet_values import ArmGoal, Grasp
from llmpas.worlds.pybullet.scene import FINGER_OPEN, Scene, open_client
from llmpas.worlds.pybullet_ros2 import standard
from llmpas.worlds.ros2 import convert
from llmpas.worlds.ros2.env import RosEnv, reclaim_shared_memory
from llmpas.worlds.ros2.names import (
    ACTIONS,
    FJT,
    GRIPPER,
    LOOK,
    NAV,
    SKILL,
    STATE,
    action_names,
)
from llmpas.worlds.ros2.profile import LATCHED, RobotProfile

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Faults:
    """Goals of these kinds are rejected, aborted or held until cancelled (tests)."""

    reject: frozenset[str] = frozenset()
    abort: frozenset[str] = frozenset()
    stall: frozenset[str] = frozenset()
    hold_accept: Path | None = None  # accept no goal before this file exists (a slow server)
    accept_after: float = 0.0  # and, when held, not before these seconds have passed


def build_world(scenario: PyBulletScenario, seed: int, client: int) -> PyBulletWorld:
    """The simulator as the in-process session builds it (the same seeded generators)."""
    from llmpas.worlds.pybullet.pybullet_plugin import WORLD as PYBULLET

    scene = Scene(client, scenario.scene)
    setup_scene(scene, scenario)
    return PyBulletWorld(
        scene,
        np.random.default_rng([seed, 0]),
        PYBULLET.camera,
        scenario.seeded_events(np.random.default_rng([seed, 4])),
        snapshots=False,
    )


class RobotNode:
    """The action servers, service and topics of one simulated robot (an rclpy node)."""

    def __init__(
        self,
        node: Any,
        world: PyBulletWorld,
        faults: Faults | None = None,
        profile: RobotProfile | None = None,
        camera_rng: np.random.Generator | None = None,
    ) -> None:
        from control_msgs.action import FollowJointTrajectory, GripperCommand
        from nav2_msgs.action import NavigateToPose
        from nav_msgs.msg import Odometry
        from rclpy.action import ActionServer, CancelResponse, GoalResponse
        from rclpy.callback_groups import ReentrantCallbackGroup
        from sensor_msgs.msg import JointState

        self.node, self.world = node, world
        self.faults = faults or Faults()
        self.profile = profile or RobotProfile()
        self.standard = self.profile.standard
        self.names = action_names(self.profile)
        self.camera_rng = camera_rng or np.random.default_rng(5)  # the detector's noise
        self.lock = threading.Lock()
        self.goals = 0
        group = ReentrantCallbackGroup()
        topics = self.profile.topics  # each published with the QoS the profile gives it
        self.odom = node.create_publisher(Odometry, topics.odom.name, topics.odom.qos.rclpy())
        self.joints = node.create_publisher(
            JointState, topics.joint_states.name, topics.joint_states.qos.rclpy()
        )
        self._accept, self._cancel = GoalResponse, CancelResponse

        def server(kind: type, name: str, run: Callable[[Any], Any]) -> Any:
            return ActionServer(
                node,
                kind,
                self.names[name],
                execute_callback=run,
                goal_callback=lambda goal: self._goal(name, goal),
                cancel_callback=lambda handle: CancelResponse.ACCEPT,
                callback_group=group,
            )

        self.types: dict[str, Any] = {
            NAV: NavigateToPose,
            FJT: FollowJointTrajectory,
            GRIPPER: GripperCommand,
        }
        self.servers = [
            server(NavigateToPose, NAV, self._navigate),
            server(FollowJointTrajectory, FJT, self._trajectory),
            server(GripperCommand, GRIPPER, self._gripper),
        ]
        if self.standard:
            self._standard_topics(group)
        else:
            from llmpas_interfaces.action import Look, Skill
            from llmpas_interfaces.msg import Detections
            from llmpas_interfaces.srv import GetSceneState
            from visualization_msgs.msg import MarkerArray

            self.types.update({SKILL: Skill, LOOK: Look})
            self.servers += [server(Skill, SKILL, self._skill), server(Look, LOOK, self._look)]
            self.detections = node.create_publisher(
                Detections, topics.detections.name, topics.detections.qos.rclpy()
            )
            self.markers = node.create_publisher(
                MarkerArray, topics.scene_markers.name, topics.scene_markers.qos.rclpy()
            )
            self.service = node.create_service(
                GetSceneState, self.profile.actions.state, self._state, callback_group=group
            )
        self.publish()

    def _standard_topics(self, group: Any) -> None:
        """A standard robot's topics: TF, the robot's description (latched, as
        robot_state_publisher does), and a detector's Detection3DArray from the mast and wrist
        cameras; state at 10 Hz, detections at 0.5 Hz and after every goal (the wrist camera's only
        after a trajectory)."""
        from std_msgs.msg import String
        from tf2_msgs.msg import TFMessage
        from vision_msgs.msg import Detection3DArray

        node, topics = self.node, self.profile.topics
        self.tf = node.create_publisher(TFMessage, topics.tf.name, topics.tf.qos.rclpy())
        self.tf_static = node.create_publisher(TFMessage, topics.tf_static.name, LATCHED.rclpy())
        self.description = node.create_publisher(
            String, topics.robot_description.name, LATCHED.rclpy()
        )
        self.detections = node.create_publisher(
            Detection3DArray, topics.detections.name, topics.detections.qos.rclpy()
        )
        self.wrist = node.create_publisher(
            Detection3DArray, topics.wrist_detections.name, topics.wrist_detections.qos.rclpy()
        )
        self.description.publish(String(data=standard.robot_description()))
        self.tf_static.publish(standard.static_transforms(self.profile, self._now()))
        self.timers = [
            node.create_timer(0.1, lambda: self._idle(self.publish), callback_group=group),
            node.create_timer(2.0, lambda: self._idle(self.see), callback_group=group),
        ]

    def _now(self) -> Any:
        return self.node.get_clock().now().to_msg()

    def _idle(self, work: Callable[[], None]) -> None:
        """Run ``work`` unless a goal holds the simulator (it publishes when it ends)."""
        if self.lock.acquire(blocking=False):
            try:
                work()
            finally:
                self.lock.release()

    def see(self, mast: bool = True) -> None:
        """The mast (unless ``mast`` is False) and wrist cameras' detections (vision_msgs), in
        the cameras' frames; the robot's TF first, so that a client finds the transforms at
        the detections' stamp."""
        self.publish()
        stamp = self._now()
        if mast:
            seen = standard.mast_detections(self.world, self.camera_rng)
            self.detections.publish(
                standard.detection_array(seen, standard.CAMERA_FRAME, stamp, self.world)
            )
        wrist = standard.wrist_detections(self.world, self.camera_rng)
        base = self.profile.frames.base
        self.wrist.publish(standard.detection_array(wrist, base, stamp, self.world))

    # ------------------------------------------------------------------ faults

    @staticmethod
    def _kind(name: str, goal: Any) -> str:
        if name == SKILL:
            return str(goal.skill)
        return name.rsplit("/", 1)[-1]

    def _goal(self, name: str, goal: Any) -> Any:
        kind = self._kind(name, goal)
        if kind in self.faults.reject:
            log.warning("rejecting a %s goal (fault)", kind)
            return self._accept.REJECT
        gate = self.faults.hold_accept
        if gate is not None and not gate.exists():
            log.warning("holding a %s goal's acceptance until %s exists (fault)", kind, gate)
            start = time.monotonic()
            earliest, end = start + self.faults.accept_after, start + 120.0
            while (not gate.exists() or time.monotonic() < earliest) and time.monotonic() < end:
                time.sleep(0.01)
            held = time.monotonic() - start
            log.warning("accepting the held %s goal after %.1f s", kind, held)
        return self._accept.ACCEPT

    def _hold(self, handle: Any, kind: str) -> bool:
        """A stalled goal: wait until it is cancelled. True when the fault applies."""
        if kind not in self.faults.stall:
            return False
        log.warning("stalling a %s goal until it is cancelled (fault)", kind)
        while not handle.is_cancel_requested:
            time.sleep(0.02)
        log.warning("the %s goal was cancelled by the client", kind)
        return True

    # ------------------------------------------------------------------ execution

    def _execute(
        self, handle: Any, name: str, act: Callable[[], SkillResult]
    ) -> tuple[SkillResult | None, bool]:
        """Run ``act`` on the simulator (one goal at a time). (result, cancelled)."""
        kind = self._kind(name, handle.request)
        if self._hold(handle, kind):
            handle.canceled()
            return None, True
        self._feedback(handle, name, kind)
        with self.lock:
            self.goals += 1
            if kind in self.faults.abort:
                result = SkillResult.failure(f"{kind} aborted by the robot", reason="aborted")
            else:
                result = act()
            if self.standard:  # a motion of the arm changes the wrist camera's view only
                self.see(mast=name != FJT)
            else:
                self.publish()
        if handle.is_cancel_requested:
            handle.canceled()
            return result, True
        if result.ok:
            handle.succeed()
        else:
            handle.abort()
        return result, False

    def _feedback(self, handle: Any, name: str, kind: str) -> None:
        """One feedback message as a goal starts (where the robot is, what it does)."""
        feedback = self.types[name].Feedback()
        if name == NAV:
            x, y, t = self.world.believed()
            feedback.current_pose = convert.pose_stamped(x, y, 0.0, t)
        elif name == FJT:
            feedback.joint_names = list(self.profile.arm.joints)
            feedback.actual.positions = [float(v) for v in self.world.scene.arm_conf()]
        elif name == GRIPPER:
            feedback.position = float(self.world.scene.finger_width())
        else:
            feedback.phase = f"running {kind}"
        handle.publish_feedback(feedback)

    def _navigate(self, handle: Any) -> Any:
        conf = convert.base_of(handle.request.pose)
        result, _ = self._execute(handle, NAV, lambda: self.world.move_base(conf))
        out = self.types[NAV].Result()
        if result is not None:
            out.error_code = 0 if result.ok else standard.nav2_error_code(result)
            out.error_msg = result.message if self.standard else _text(result)
        return out

    def _trajectory(self, handle: Any) -> Any:
        goal = handle.request
        out = self.types[FJT].Result()
        names = list(goal.trajectory.joint_names)
        points = goal.trajectory.points
        joints = list(self.profile.arm.joints)
        if sorted(names) != sorted(joints) or not points:
            handle.abort()
            out.error_code = out.INVALID_JOINTS
            out.error_string = f"expected the joints {', '.join(joints)}"
            return out
        order = [names.index(j) for j in joints]
        path = [tuple(float(pt.positions[i]) for i in order) for pt in points]

        def move() -> SkillResult:
            if self.standard:  # a controller: follow the client's trajectory point by point
                self.world.skills.follow(path)
                return SkillResult.success(f"followed {len(path)} points")
            if self.world.skills.move_arm(path[-1]):
                return SkillResult.success("arm folded")
            return SkillResult.failure("cannot fold")

        result, _ = self._execute(handle, FJT, move)
        if result is not None:
            out.error_code = out.SUCCESSFUL if result.ok else out.PATH_TOLERANCE_VIOLATED
            out.error_string = _text(result)
        return out

    def _gripper(self, handle: Any) -> Any:
        """ros2_control's gripper action: open (a position of 4 cm or more; lets go of what
        it holds) or close with ``max_effort`` (holds an object that ends between the fingers;
        then the fingers stall on it)."""
        cmd = handle.request.command
        scene, config = self.world.scene, self.world.skills.config

        def act() -> SkillResult:
            if cmd.position >= FINGER_OPEN - 1e-3:
                held = scene.held
                if held is not None:
                    scene.detach()
                scene.drive_fingers(FINGER_OPEN)
                scene.step(config.release_steps)
                if held is not None and self.standard:  # the scenario's events on a release
                    self.world._done("release", SkillResult.success(f"released {held}"))
                return SkillResult.success("opened")
            scene.drive_fingers(max(0.0, float(cmd.position)), cmd.max_effort or config.grip_force)
            scene.step(config.close_steps)
            ee, _ = scene.ee_pose()
            near = sorted(
                (float(np.linalg.norm(scene.pose(o.name)[0] - ee)), o.name)
                for o in scene.config.objects
                if o.graspable
            )
            if scene.finger_width() > 0.01 and near and near[0][0] < 0.05:
                scene.attach(near[0][1])
                if self.standard:  # the scenario's events on a grasp
                    self.world._done("grasp", SkillResult.success(f"holding {near[0][1]}"))
                return SkillResult.success(f"holding {near[0][1]}")
            return SkillResult.success("closed")

        result, _ = self._execute(handle, GRIPPER, act)
        out = self.types[GRIPPER].Result()
        out.position = float(scene.finger_width())
        out.stalled = scene.held is not None
        out.reached_goal = result is not None and result.ok and scene.held is None
        out.effort = float(cmd.max_effort) if out.stalled else 0.0
        return out

    def _skill(self, handle: Any) -> Any:
        goal = handle.request
        result, _ = self._execute(handle, SKILL, lambda: self._do(goal.skill, goal.args))
        out = self.types[SKILL].Result()
        if result is not None:
            out.success, out.message = result.ok, result.message
            out.reason = str(result.data.get("reason", ""))
        return out

    def _do(self, skill: str, args: str) -> SkillResult:
        import json

        w = self.world
        try:
            a = json.loads(args) if args else {}
            if skill == "move_arm":
                goal: ArmGoal = convert.arm_goal(args)
                return w.move_arm(goal)
            if skill == "grasp":
                return w.grasp(a["obj"], Grasp(a["grasp"]))
            if skill == "release":
                return w.release(a["obj"], convert.object_pose(a["pose"]))
            if skill == "open":
                return w.open(a["container"])
            if skill == "close":
                return w.close(a["container"])
            if skill == "process":
                return w.process(a["obj"], a["appliance"], a["how"])
        except (KeyError, ValueError, TypeError) as e:
            return SkillResult.failure(f"bad {skill} goal: {e}", reason="bad_value")
        return SkillResult.failure(f"no skill {skill!r} on this robot", reason="unknown_skill")

    def _look(self, handle: Any) -> Any:
        goal = handle.request
        seen: list[Observation] = []

        def look() -> SkillResult:
            seen.append(self._observe(goal.camera, goal.region or None, goal.target))
            return SkillResult.success(f"{len(seen[0].detections)} detections")

        result, _ = self._execute(handle, LOOK, look)
        out = self.types[LOOK].Result()
        if result is not None:
            out.success, out.message = result.ok, result.message
        if seen:
            out.detections = convert.detections_msg(seen[0], goal.camera)
            out.detections.header.stamp = self.node.get_clock().now().to_msg()
            self.detections.publish(out.detections)
        return out

    def _observe(self, camera: str, region: str | None, target: str) -> Observation:
        w = self.world
        if camera == "arm":
            return w.look_with_arm(region)
        if camera == "wrist":
            pose = w.wrist_detect(target)
            dets = () if pose is None else (Detection(target, pose.region, pose),)
            return Observation((), dets)
        return w.look(region)

    def _state(self, request: Any, response: Any) -> Any:
        with self.lock:
            response.state = convert.scene_state(self.world.scene, self.world.believed())
        return response

    # ------------------------------------------------------------------ topics

    def publish(self) -> None:
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import JointState

        now = self.node.get_clock().now().to_msg()
        frames = self.profile.frames
        x, y, t = self.world.believed()
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = now, frames.odom
        odom.child_frame_id = frames.base
        odom.pose.pose = convert.pose_stamped(x, y, 0.0, t).pose
        self.odom.publish(odom)
        js = JointState()
        js.header.stamp = now
        js.name = list(self.profile.arm.joints)
        js.position = [float(v) for v in self.world.scene.arm_conf()]
        self.joints.publish(js)
        if self.standard:
            self.tf.publish(standard.base_transforms(self.profile, (x, y, t), now))
        else:
            self.markers.publish(scene_markers(self.world.scene, now))


def scene_markers(scene: Scene, stamp: Any) -> Any:
    """The scene's objects and tables as cubes/cylinders in ``map`` (true poses)."""
    from visualization_msgs.msg import Marker, MarkerArray

    out = MarkerArray()
    k = 0
    for t in scene.config.tables:
        m = Marker()
        m.header.frame_id, m.header.stamp = convert.FRAME, stamp
        m.ns, m.id, m.type, m.action = "tables", k, Marker.CUBE, Marker.ADD
        m.pose = convert.pose_stamped(t.x, t.y, 0.35, t.yaw).pose
        m.scale.x, m.scale.y, m.scale.z = 1.5, 1.0, 0.7
        m.color.r = m.color.g = m.color.b = 0.6
        m.color.a = 1.0
        m.text = t.name
        out.markers.append(m)
        k += 1
    for o in scene.config.objects:
        at, _ = scene.pose(o.name)
        m = Marker()
        m.header.frame_id, m.header.stamp = convert.FRAME, stamp
        m.ns, m.id, m.action = "objects", k, Marker.ADD
        m.type = Marker.CYLINDER if o.kind == "bowl" else Marker.CUBE
        m.pose = convert.pose_stamped(float(at[0]), float(at[1]), float(at[2])).pose
        m.scale.x = m.scale.y = float(o.size)
        m.scale.z = float(o.height)
        m.color.g, m.color.a = 0.8, 1.0
        m.text = o.name
        out.markers.append(m)
        k += 1
    return out


def _text(result: SkillResult) -> str:
    """A result's message with its reason, for interfaces with one text field."""
    import json

    return json.dumps({"message": result.message, "reason": result.data.get("reason", "")})


def serve(
    scenario: str,
    seed: int | None,
    env: RosEnv,
    faults: Faults,
    ready: Path | None = None,
    profile: RobotProfile | None = None,
    truth: Path | None = None,
) -> None:
    """Build the simulator and serve it until SIGINT/SIGTERM (rclpy's handlers end the spin);
    then write the true final state to ``truth``."""
    env.apply()
    reclaim_shared_memory()  # what killed nodes left in /dev/shm
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

    chosen = resolve(scenario)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=env.domain, signal_handler_options=None)
    with open_client(False) as client:
        seed = chosen.seed if seed is None else seed
        world = build_world(chosen, seed, client)
        profile = profile or RobotProfile()
        node = rclpy.create_node(
            "llmpas_pybullet_robot", context=context, namespace=profile.namespace or None
        )
        robot = RobotNode(node, world, faults, profile, np.random.default_rng([seed, 5]))
        executor = MultiThreadedExecutor(num_threads=4, context=context)
        executor.add_node(node)
        log.info(
            "robot %s (seed %s) on ROS_DOMAIN_ID=%d, discovery %s, %s interfaces: serving %s",
            chosen.name,
            seed,
            env.domain,
            env.discovery,
            profile.interfaces,
            ", ".join(node.resolve_topic_name(robot.names[k]) for k in robot.types),
        )
        if ready is not None:
            ready.write_text(f"{robot.goals}\n")
        signal.signal(signal.SIGTERM, _interrupt)  # SIGTERM ends the spin as SIGINT does
        try:
            executor.spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
            if truth is not None:
                write_truth(truth, world, chosen.name, chosen.goal)


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def write_truth(path: Path, world: Any, scenario: str, goal: str) -> None:
    """The simulator's true state as JSON (atomically): its facts and whether the scenario's
    goal holds in them."""
    import json

    from llmpas.files import atomic_write
    from llmpas.worlds.api import holds
    from llmpas.worlds.pybullet.facts import true_facts

    facts = true_facts(world.scene)
    about = {
        "scenario": scenario,
        "goal": goal,
        "goal_holds": holds(goal, facts),
        "facts": sorted(str(f) for f in facts),
        "held": world.scene.held,
        "poses": {  # every object's position in the map (m)
            o.name: [round(float(v), 4) for v in world.scene.pose(o.name)[0]]
            for o in world.scene.config.objects
        },
    }
    atomic_write(path, json.dumps(about, indent=2))
    log.info("wrote the true final state to %s", path)


__all__ = [
    "ACTIONS",
    "FJT",
    "GRIPPER",
    "LOOK",
    "NAV",
    "SKILL",
    "STATE",
    "Faults",
    "RobotNode",
    "serve",
]
