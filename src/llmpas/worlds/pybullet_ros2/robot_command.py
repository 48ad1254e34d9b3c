"""``llmpas robot pybullet SCENARIO``: serve the PyBullet Husky + Panda as a ROS 2 robot.

The ROS 2 world's own command, registered as ``ROBOT_ENTRY`` in this package's ``__init__``; the
command line hands it everything after ``llmpas robot pybullet`` and this module's parser is the
only one (``python -m llmpas.worlds.pybullet_ros2`` uses it too).
"""

from __future__ import annotations

import argparse
import importlib.util
import logging
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from llmpas.errors import LlmpasError, UsageError, one_line
from llmpas.worlds.pybullet.pybullet_scenarios import (
    scenarios,  # pybullet's banner: while the registry loads us
)

FAULTS = ("reject", "abort", "stall")


def parser(prog: str = "llmpas robot pybullet") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog, description="serve the PyBullet Husky + Panda as a ROS 2 robot (docs/ros.md)"
    )
    p.add_argument("scenario", help="its scenario (object-loss, nominal, ...)")
    p.add_argument("--seed", type=int, help="the scenario's seed (default: its own)")
    p.add_argument("--domain", type=int, help="ROS_DOMAIN_ID (default: $ROS_DOMAIN_ID, else 57)")
    p.add_argument("--log-dir", help="ROS_LOG_DIR and the node's files (default: a temp folder)")
    p.add_argument("--ready", help="write this file once every server is up")
    p.add_argument(
        "--truth",
        metavar="FILE",
        help="write the simulator's true final state here when the robot stops (JSON: facts, "
        "the scenario's goal and whether it holds), to check a client's perceived verdict",
    )
    p.add_argument(
        "--robot-profile",
        metavar="FILE",
        help="its profile: action and topic names, namespace, QoS of its publishers "
        "(YAML, or a shipped name: pybullet, pybullet-standard)",
    )
    p.add_argument(
        "--standard",
        action="store_true",
        help="serve standard interfaces only: Nav2, ros2_control's two actions, TF, "
        "joint_states, robot_description, vision_msgs/Detection3DArray",
    )
    for fault in FAULTS:
        p.add_argument(
            f"--{fault}",
            action="append",
            default=[],
            metavar="KIND",
            help=f"{fault} goals of KIND (navigate_to_pose, follow_joint_trajectory, look, "
            "or a skill: grasp, release, move_arm, ...); for tests",
        )
    p.add_argument(
        "--hold-accept",
        metavar="FILE",
        help="accept no goal before FILE exists (a server slow to accept; for tests)",
    )
    p.add_argument(
        "--accept-after",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="with --hold-accept: hold a goal's acceptance at least SECONDS too (for tests)",
    )
    return p


def run(argv: Sequence[str]) -> int:
    """Parse ``argv`` and serve until SIGINT/SIGTERM; a bad scenario, domain or a missing
    ``ros`` extra is a :class:`~llmpas.errors.UsageError` (one line)."""
    args = parser().parse_args(list(argv))
    if importlib.util.find_spec("rclpy") is None:
        raise UsageError('robot: needs the ros extra (pip install -e ".[ros]"): no rclpy')
    from llmpas.worlds.pybullet_ros2.node import Faults, serve
    from llmpas.worlds.ros2.env import from_environment, missing_rmw
    from llmpas.worlds.ros2.profile import ProfileError
    from llmpas.worlds.ros2.profile import load as load_profile

    known = scenarios()
    if args.scenario not in known:
        raise UsageError(f"no scenario {args.scenario!r}; known: {', '.join(sorted(known))}")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s robot: %(message)s", force=True)
    log_dir = Path(args.log_dir or tempfile.mkdtemp(prefix="llmpas-robot-"))
    try:
        profile = load_profile(args.robot_profile or "pybullet")
        if args.standard and not profile.standard:
            profile = (
                replace(profile, interfaces="standard")
                if args.robot_profile
                else load_profile("pybullet-standard")
            )
        env = from_environment(log_dir / "ros", args.domain, profile.rmw)
    except ProfileError as e:
        raise UsageError(str(e)) from None
    except ValueError as e:
        raise UsageError(str(e.args[0] if e.args else e)) from None
    problem = missing_rmw(env.environ())
    if problem is not None:
        raise UsageError(problem)
    hold = Path(args.hold_accept) if args.hold_accept else None
    if not (0.0 <= args.accept_after <= 60.0):
        raise UsageError(f"--accept-after {args.accept_after}: give 0 to 60 seconds")
    faults = Faults(
        frozenset(args.reject), frozenset(args.abort), frozenset(args.stall), hold,
        args.accept_after,
    )  # fmt: skip
    ready = Path(args.ready) if args.ready else None
    truth = Path(args.truth) if args.truth else None
    if truth is not None and not truth.parent.is_dir():
        raise UsageError(f"--truth {truth}: no folder {truth.parent}")
    serve(args.scenario, args.seed, env, faults, ready, profile, truth)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """The command outside the CLI (``python -m llmpas.worlds.pybullet_ros2``): errors in one
    line."""
    try:
        return run(sys.argv[1:] if argv is None else argv)
    except LlmpasError as e:
        sys.stderr.write(f"error: {one_line(str(e))}\n")
        return int(e.code)


__all__ = ["main", "parser", "run"]
