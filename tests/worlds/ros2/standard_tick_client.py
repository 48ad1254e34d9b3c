"""The client side of test_standard_tick, in a process of its own: the STANDARD client
(:class:`~llmpas.worlds.ros2.standard_robot.StandardRobot`, its planning scene built from the
shipped house site and the robot's ``robot_description``) runs two subtrees and writes what
happened as JSON. Nothing here times anything: the guards count the ticks.

1. ``drive``: two base goals; the robot holds the first goal's acceptance at least 2 s and until
   ``GATE`` exists, which the guard writes at its ``OPEN_AT``-th check (a server slow to accept),
   then stalls each goal until it is cancelled; the guard fails at its ``FAIL_AT``-th check of
   an accepted goal, which cancels the goal on the server.
2. ``fold``: folding the arm, whose trajectory planning is held until the guard's
   ``PLANNED_AT``-th check (a planner that takes long).

``python -m tests.worlds.ros2.standard_tick_client DOMAIN FOLDER OUT GATE``
"""

from __future__ import annotations

import json
import sys
import threading
from pathlib import Path
from typing import Any

OPEN_AT = 12  # the guard's check that lets the server accept the first goal
FAIL_AT = 30  # the guard's check (of one goal) that fails
PLANNED_AT = 12  # the guard's check that lets the planner finish


def main(domain: int, folder: Path, out: Path, gate: Path) -> None:
    import numpy as np

    from llmpas.execution.context import Belief, Context
    from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec
    from llmpas.execution.executor import ExecutorConfig, execute
    from llmpas.execution.space import Dimension
    from llmpas.language.logic import Atom
    from llmpas.worlds.pybullet.pybullet_values import BaseConf
    from llmpas.worlds.pybullet.scene import open_client
    from llmpas.worlds.ros2.env import RosEnv
    from llmpas.worlds.ros2.process import ros_context
    from llmpas.worlds.ros2.profile import load as load_profile
    from llmpas.worlds.ros2.robot_model import arm_model
    from llmpas.worlds.ros2.site import load as load_site
    from llmpas.worlds.ros2.site_scene import SiteScene
    from llmpas.worlds.ros2.standard_robot import StandardRobot

    site, profile = load_site("house"), load_profile("pybullet-standard")
    with ros_context(RosEnv(domain, folder / "log")) as context, open_client(False) as client:

        def build(description: str, base: tuple[float, float, float]) -> Any:
            arm = arm_model(description, profile.arm.joints[0], profile.frames.base)
            return SiteScene(client, site, arm, base)

        robot = StandardRobot(context, None, profile, np.random.default_rng(0), None, None, build)
        try:
            robot.wait_for_servers()
            x, y, t = robot.believed
            bases = [BaseConf(x + 0.3, y, t), BaseConf(x, y + 0.3, t)]
            checks: dict[str, int] = {}
            accepted: dict[str, int] = {}  # checks once the goal was accepted
            at_open: dict[str, int] = {}
            polls = [robot.polls_accepting]

            def still_seen(v: Any, c: Context) -> str | None:
                key = str(v["base"])
                checks[key] = checks.get(key, 0) + 1
                if checks[key] == OPEN_AT and not gate.exists():
                    at_open["polls_accepting"] = robot.polls_accepting
                    gate.write_text("open\n")
                pending, polls[0] = robot.polls_accepting != polls[0], robot.polls_accepting
                if not pending:  # the tick no longer polls for its acceptance
                    accepted[key] = accepted.get(key, 0) + 1
                return "the cube is no longer seen" if accepted.get(key) == FAIL_AT else None

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
            drives, cancels = robot.goals, robot.cancels

            # the planner held until the tree has ticked PLANNED_AT times
            planned = threading.Event()
            fold_checks = [0]
            home = robot.skills.home

            def slow_home() -> bool:
                planned.wait(120)
                return home()

            robot.skills.home = slow_home  # type: ignore[method-assign]

            def ticking(v: Any, c: Context) -> str | None:
                fold_checks[0] += 1
                if fold_checks[0] == PLANNED_AT:
                    planned.set()
                return None

            ticked = Constraint("Ticking", ticking, lambda v: Atom("seen", ("cube",)), ())
            fold = SubAction("move_arm", lambda v, c: c.robot.move_arm("home"), guards=(ticked,))
            spec2 = SubtreeSpec("fold", (1,), "fold", (), {}, (), (fold,))
            ctx2 = Context(robot, robot, Belief([], {}), np.random.default_rng(0))
            ep2 = execute([spec2], ctx2, ExecutorConfig(period=0.02))
            report = {
                "status": ep.status.value,
                "ticks": ep.ticks,
                "checks": list(checks.values()),
                "checks_accepted": list(accepted.values()),
                "polls_accepting_at_open": at_open.get("polls_accepting", -1),
                "goals": drives,
                "cancels": cancels,
                "events": [[e.node, e.status, e.message] for e in ep.events],
                "fold_status": ep2.status.value,
                "fold_checks": fold_checks[0],
                "polls_planning": robot.polls_planning,
            }
        finally:
            robot.shutdown()
    out.write_text(json.dumps(report, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]), Path(sys.argv[4]))
