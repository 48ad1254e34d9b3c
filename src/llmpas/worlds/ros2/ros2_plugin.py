"""The ROS 2 world (``--world ros2``): a robot reached over ROS 2.

With a site (``--site FILE``, :mod:`llmpas.worlds.ros2.site`) and a standard robot, the session
plans from what the robot gives (``robot_description``, TF, ``joint_states``, detections) and
what the site says, nothing else (:mod:`llmpas.worlds.ros2.site_session`); the task is one of
the site's. Without a site it runs the PyBullet world's scenarios with their robot reached over
ROS 2 (:mod:`llmpas.worlds.ros2.ros2_session`), imported only then.

By default a session starts the PyBullet robot node in a process of its own, on a fresh random
``ROS_DOMAIN_ID`` with discovery kept on localhost, and stops it at the end.
``LLMPAS_ROS_ROBOT=external`` connects to a robot that is already serving instead (``llmpas
robot pybullet SCENARIO``, or a real robot: docs/ros.md), on ``ROS_DOMAIN_ID`` and the
discovery range of ``LLMPAS_ROS_DISCOVERY``.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from llmpas.worlds.api import RunOptions
from llmpas.worlds.pybullet.camera import CameraConfig
from llmpas.worlds.pybullet.pybullet_decomposition import ExplorationConfig
from llmpas.worlds.pybullet.scene import open_client
from llmpas.worlds.ros2.client import RobotUnavailableError, Timeouts
from llmpas.worlds.ros2.env import (
    RosEnv,
    from_environment,
    missing_rmw,
    random_domain,
    reclaim_shared_memory,
)
from llmpas.worlds.ros2.process import RosError, robot_process, ros_context
from llmpas.worlds.ros2.profile import ProfileError, RobotProfile
from llmpas.worlds.ros2.profile import load as load_profile
from llmpas.worlds.ros2.site import Site, SiteError
from llmpas.worlds.ros2.site import load as load_site

log = logging.getLogger(__name__)

ROBOT_VAR = "LLMPAS_ROS_ROBOT"  # "external": connect to a running robot, start none
TIMEOUT_VAR = "LLMPAS_ROS_DISCOVER_TIMEOUT"  # seconds to find every server (default 30)


def read_site(path: str, task: str, profile: RobotProfile) -> Site:
    """The site file, checked against the task and the profile (one line naming the file and
    the key when it cannot be used)."""
    try:
        site = load_site(path)
    except SiteError as e:
        raise RosError(str(e)) from None
    try:
        site.task(task)
    except KeyError as e:
        raise RosError(str(e.args[0])) from None
    if not profile.standard:
        raise RosError(
            f"--site: the robot profile {profile.source or profile.name} speaks "
            "llmpas's interfaces; a site is for a standard robot (interfaces: standard)"
        )
    return site


@dataclass(frozen=True)
class Ros2Plugin:
    """The ROS 2 world: a standard robot and a site, or the PyBullet scenarios over ROS 2."""

    camera: CameraConfig = field(default_factory=CameraConfig)
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    timeouts: Timeouts = field(default_factory=Timeouts)
    name: str = "ros2"
    title: str = "ROS 2: the PyBullet Husky + Franka Panda as a ROS 2 robot"

    def scenarios(self) -> dict[str, str]:
        from llmpas.worlds.pybullet.pybullet_scenarios import scenarios

        return {name: s.description for name, s in scenarios().items()}

    def _timed(self) -> Ros2Plugin:
        wait = os.environ.get(TIMEOUT_VAR, "").strip()
        if not wait:
            return self
        try:
            return replace(self, timeouts=replace(self.timeouts, discover=float(wait)))
        except ValueError:
            raise RosError(f"{TIMEOUT_VAR}={wait!r}: not a number of seconds") from None

    @contextmanager
    def open(self, scenario: Any, options: RunOptions) -> Iterator[Any]:
        plugin = self._timed()
        try:
            profile = load_profile(options.robot_profile or "pybullet")
        except ProfileError as e:
            raise RosError(str(e)) from None
        site = None
        if options.site:
            site = read_site(options.site, str(scenario), profile)
            name, seed = str(scenario), 0 if options.seed is None else options.seed
        else:
            from llmpas.worlds.pybullet.pybullet_scenarios import resolve

            chosen = resolve(scenario)
            name, seed = chosen.name, chosen.seed if options.seed is None else options.seed
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
            if not external:  # the simulated robot, in a process of its own
                extra = ("--robot-profile", profile.source) if profile.source else ()
                stack.enter_context(robot_process(name, seed, env, folder, extra))
            context = stack.enter_context(ros_context(env))
            client = stack.enter_context(open_client(False, data=site is None))
            try:
                session = self._session(plugin, scenario, site, options, client, context,
                                        folder, profile)  # fmt: skip
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

    @staticmethod
    def _session(
        plugin: Ros2Plugin,
        scenario: Any,
        site: Site | None,
        options: RunOptions,
        client: int,
        context: Any,
        folder: Path,
        profile: RobotProfile,
    ) -> Any:
        if site is not None:
            from llmpas.worlds.ros2.site_session import SiteSession

            return SiteSession(site.task(str(scenario)), site, plugin, options, client, context,
                               folder, profile)  # fmt: skip
        from llmpas.worlds.pybullet.pybullet_scenarios import resolve
        from llmpas.worlds.ros2.ros2_session import Ros2Session

        return Ros2Session(resolve(scenario), plugin, options, client, context, folder, profile)


WORLD = Ros2Plugin()

__all__ = ["ROBOT_VAR", "TIMEOUT_VAR", "WORLD", "Ros2Plugin", "read_site"]
