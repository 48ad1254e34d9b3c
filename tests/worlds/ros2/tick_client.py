"""The client side of test_tick, in a process of its own (rclpy's variables are set before it
starts): one drive of the PyBullet robot over ROS 2 as a CSubBT whose guard, checked every
tick while the ``navigate_to_pose`` goal runs, fails on its ``FAIL_AT``-th check of a goal (a
stand-in for "the cube is no longer seen"). Writes what happened as JSON.

``python -m tests.worlds.ros2.tick_client DOMAIN FOLDER OUT``
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

FAIL_AT = 15  # the guard's check (of one goal) that fails


def main(domain: int, folder: Path, out: Path) -> None:
    import numpy as np

    from llmpas.execution.context import Belief, Context
    from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec
    from llmpas.execution.executor import ExecutorConfig, execute
    from llmpas.execution.space import Dimension
    from llmpas.language.logic import Atom
    from llmpas.worlds.pybullet.pybullet_scenarios import resolve
    from llmpas.worlds.pybullet.pybullet_values import BaseConf
    from llmpas.worlds.pybullet.scene import Scene, open_client
    from llmpas.worlds.ros2.client import RosRobot
    from llmpas.worlds.ros2.env import RosEnv
    from llmpas.worlds.ros2.ros2_session import ros_context

    with ros_context(RosEnv(domain, folder / "log")) as context, open_client(False) as client:
        robot = RosRobot(context, Scene(client, resolve("object-loss").scene))
        try:
            robot.wait_for_servers()
            x, y, t = robot.believed
            bases = [BaseConf(x + 0.5, y, t), BaseConf(x, y + 0.5, t)]
            checks: dict[str, int] = {}

            def still_seen(v: Any, c: Context) -> str | None:
                key = str(v["base"])
                checks[key] = checks.get(key, 0) + 1
                return "the cube is no longer seen" if checks[key] == FAIL_AT else None

            seen = Constraint("Seen", still_seen, lambda v: Atom("seen", ("cube",)), ("base",))
            drive = SubAction(
                "move_base",
                lambda v, c: c.robot.move_base(v["base"]),
                needs=("base",),
                guards=(seen,),
            )
            dims = (Dimension("base", lambda v: list(bases), budget=2),)
            spec = SubtreeSpec("drive", (0,), "move", (), {}, dims, (drive,))
            ctx = Context(robot, robot, Belief([], {}), np.random.default_rng(0))
            ep = execute([spec], ctx, ExecutorConfig(period=0.02))
            report = {
                "status": ep.status.value,
                "ticks": ep.ticks,
                "polls": ctx.polls,
                "checks": list(checks.values()),
                "goals": robot.goals,
                "events": [[e.node, e.status, e.message] for e in ep.events],
            }
        finally:
            robot.shutdown()
    out.write_text(json.dumps(report, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]))
