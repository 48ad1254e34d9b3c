"""Scenarios of the PyBullet world: the scene, what the robot believes, the goal and what
happens behind its back; how the scene is set up, the initial belief, the judge of the goal in the
true state, and the world's files for a run folder (snapshots, camera images, a GIF).

The simulator's true state is used only to build the world, to fire scenario events and to judge
the outcome afterwards.
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.context import Belief
from llmpas.files import atomic_write
from llmpas.worlds.pybullet.facts import bottom, goal_holds, over, true_facts
from llmpas.worlds.pybullet.pybullet_problem import initial_belief
from llmpas.worlds.pybullet.pybullet_robot import Event, PyBulletWorld
from llmpas.worlds.pybullet.pybullet_values import BaseConf, ObjectPose
from llmpas.worlds.pybullet.scene import (
    TABLE_TOP,
    ObjectConfig,
    Scene,
    SceneConfig,
    TableConfig,
    table_rect,
)
from llmpas.worlds.pybullet.snapshot import save_media

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PyBulletScenario:
    """A world, what the robot believes, a goal, and what happens behind the robot's back."""

    name: str
    description: str
    scene: SceneConfig
    goal: str
    seed: int = 0
    inside: tuple[tuple[str, str], ...] = ()  # (object, bowl): starts inside the bowl
    covers: tuple[tuple[str, str], ...] = ()  # (lid, bowl): starts lying on the bowl's rim
    unknown: tuple[str, ...] = ()  # objects the robot does not know the whereabouts of
    events: tuple[Event, ...] = ()
    belief_noise: float = 0.0  # metres: error of the believed initial object positions
    event_jitter: float = 0.0  # metres: seeded spread of where events put objects

    def __post_init__(self) -> None:
        names = {o.name for o in self.scene.objects}
        for obj, bowl in (*self.inside, *self.covers):
            if obj not in names or bowl not in names:
                raise ValueError(f"scenario {self.name!r}: unknown object in {(obj, bowl)}")
        for n in (*self.unknown, *(e.obj for e in self.events)):
            if n not in names:
                raise ValueError(f"scenario {self.name!r}: unknown object {n!r}")
        if self.belief_noise < 0 or self.event_jitter < 0:
            raise ValueError("belief_noise and event_jitter must be >= 0")

    def seeded_events(self, rng: np.random.Generator) -> tuple[Event, ...]:
        """The events, their drop points spread by ``event_jitter`` (clipped to stay on the
        table, 12 cm from its edges)."""
        if not self.event_jitter:
            return self.events
        out = []
        for e in self.events:
            rect = table_rect(self.scene.table(e.table))
            half = ((rect.x1 - rect.x0) / 2, (rect.y1 - rect.y0) / 2)
            dx, dy = rng.normal(0.0, self.event_jitter, 2)
            out.append(
                replace(
                    e,
                    dx=float(np.clip(e.dx + dx, -half[0] + 0.12, half[0] - 0.12)),
                    dy=float(np.clip(e.dy + dy, -half[1] + 0.12, half[1] - 0.12)),
                )
            )
        return tuple(out)


def _objects(*extra: ObjectConfig) -> tuple[ObjectConfig, ...]:
    return (
        ObjectConfig("cube", "cube", "table1", -0.33, 0.15, "green"),
        ObjectConfig("bowl", "bowl", "table2", -0.1, -0.3, "white", 0.16),
        *extra,
    )


def _four_tables() -> tuple[TableConfig, ...]:
    """table1 and table2 as in the default scene, table3 behind the robot's start (opposite
    table2) and table4 behind it the other way (opposite table1)."""
    return (
        TableConfig("table1", 1.6, 0.0, math.pi / 2),
        TableConfig("table2", 0.0, 1.9),
        TableConfig("table3", 0.0, -1.9),
        TableConfig("table4", -1.8, 0.0, math.pi / 2),
    )


def _workshop() -> SceneConfig:
    """A workshop, laid out apart from the house: a workbench ahead of the robot's start (it
    starts facing +y), a long counter to its right, a small cart behind it on the left; tables
    of other sizes than pybullet_data's, a smaller blue block and a wider tray."""
    return SceneConfig(
        tables=(
            TableConfig("workbench", 0.0, 1.7, 0.0, (1.2, 0.7)),
            TableConfig("counter", 1.8, 0.2, 0.0, (0.7, 1.8)),
            TableConfig("cart", -1.6, -0.6, 0.0, (0.8, 0.6)),
        ),
        objects=(
            ObjectConfig("block", "cube", "workbench", 0.25, -0.15, "blue", 0.04),
            ObjectConfig("tray", "bowl", "counter", -0.1, 0.35, "white", 0.2),
        ),
        base=(0.0, 0.0, math.pi / 2),
    )


def scenarios() -> dict[str, PyBulletScenario]:
    goal = "(and (On cube bowl))"
    blocker = ObjectConfig("black_cube", "cube", "table2", 0.5, 0.3, "black")
    lid = ObjectConfig("lid", "lid", "table2", 0.45, 0.25, "red", 0.2)  # laid on the bowl
    return {
        s.name: s
        for s in (
            PyBulletScenario(
                "nominal",
                "Put the green cube from table1 into the bowl on table2. Tolerable disturbances: "
                "odometry and detection noise, believed positions off by a few centimetres, and "
                "the cube nudged on its table while the robot drives.",
                SceneConfig(objects=_objects()),
                goal,
                seed=0,
                events=(Event("move_base", 1, "cube", "table1", -0.3, 0.1),),
                belief_noise=0.02,
                event_jitter=0.08,
            ),
            PyBulletScenario(
                "object-loss",
                "Object loss that needs reasoning: while the robot drives to table1 for the "
                "cube, someone carries the cube to table4, behind the robot's start (opposite "
                "table1), where no look of the pick's search sees it: from its base poses "
                "facing table1 the mast and wrist cameras see table1, table2 (the bowl) and "
                "part of table3, never table4. The robot still believes it is on table1; it "
                "could be on table2, table3 or table4. Replanning the task alone cannot find "
                "it: a search of the right table is what recovers.",
                SceneConfig(tables=_four_tables(), objects=_objects()),
                goal,
                seed=2,
                events=(Event("move_base", 1, "cube", "table4", 0.3, 0.2),),
                event_jitter=0.05,
            ),
            PyBulletScenario(
                "object-loss-seen",
                "Object loss the robot sees: while it drives to table1 for the cube, someone "
                "moves the cube to table2 (the bowl's table), which the robot's mast camera "
                "sees while it searches table1; replanning the task alone recovers.",
                SceneConfig(objects=_objects()),
                goal,
                seed=2,
                events=(Event("move_base", 1, "cube", "table2", 0.35, -0.3),),
                event_jitter=0.08,
            ),
            PyBulletScenario(
                "action-blocking",
                "Action blocking that needs reasoning: put the green cube into the bowl. Someone "
                "has laid a red lid on the bowl, which the robot does not know about. Its camera "
                "sees the lid on table2 (lying on the bowl's rim, not in it), so nothing it "
                "believes says the bowl cannot be put into: the place stops when the robot sees "
                "the lid over the spot. Replanning the task alone repeats the place; taking the "
                "lid off the bowl is what recovers.",
                SceneConfig(objects=_objects(lid)),
                goal,
                seed=6,
                covers=(("lid", "bowl"),),
                unknown=("lid",),
            ),
            PyBulletScenario(
                "workshop-moved",
                "A workshop (workbench, counter, cart): put the blue block from the workbench "
                "into the tray on the counter. While the robot drives to the workbench, someone "
                "moves the block onto the counter beside the tray. The pick fails where the "
                "robot was told the block was; it must find the block again and recover.",
                _workshop(),
                "(and (On block tray))",
                seed=3,
                events=(Event("move_base", 1, "block", "counter", -0.1, -0.45),),
            ),
            PyBulletScenario(
                "action-blocking-seen",
                "Action blocking the robot sees: put the green cube into the bowl. The bowl "
                "already holds the black cube, which the robot does not know about; the bowl "
                "holds one object. The robot sees the black cube in the bowl, so replanning the "
                "task alone recovers (it takes the black cube out first).",
                SceneConfig(objects=_objects(blocker)),
                goal,
                seed=6,
                inside=(("black_cube", "bowl"),),
                unknown=("black_cube",),
            ),
        )
    }


def setup_scene(scene: Scene, scenario: PyBulletScenario) -> None:
    for obj, bowl in scenario.inside:
        at, _ = scene.pose(bowl)
        height = scene.config.obj(obj).height
        scene.set_pose(obj, (float(at[0]), float(at[1]), TABLE_TOP + 0.01 + height / 2 + 0.003))
    for lid, bowl in scenario.covers:
        at, _ = scene.pose(bowl)
        rim = float(at[2]) + scene.config.obj(bowl).height
        scene.set_pose(lid, (float(at[0]), float(at[1]), rim + scene.config.obj(lid).height / 2))
    scene.settle(120)


def belief_for(scene: Scene, scenario: PyBulletScenario, rng: np.random.Generator) -> Belief:
    """The robot's initial belief: where it was told the objects are (the initial layout, with
    ``belief_noise``), nothing about the ``unknown`` ones."""
    poses: dict[str, ObjectPose | None] = {}
    for o in scene.config.objects:
        if o.name in scenario.unknown:
            continue
        rect = scene.tables[o.table]
        cx, cy = rect.center
        dx, dy = rng.normal(0.0, scenario.belief_noise, 2) if scenario.belief_noise else (0, 0)
        z = TABLE_TOP + o.origin_height
        poses[o.name] = ObjectPose(
            o.table, round(cx + o.dx + float(dx), 3), round(cy + o.dy + float(dy), 3), z
        )
    x, y, t = scene.config.base
    return initial_belief(scene.config, poses, BaseConf(x, y, t))


def resolve(scenario: PyBulletScenario | str) -> PyBulletScenario:
    if isinstance(scenario, PyBulletScenario):
        return scenario
    known = scenarios()
    if scenario not in known:
        raise KeyError(f"no scenario {scenario!r}; known: {', '.join(sorted(known))}")
    return known[scenario]


def save_world(world: PyBulletWorld, folder: str | Path, about: dict[str, Any]) -> list[Path]:
    """Snapshots and camera images (with ``media.json``: where each was made, for the web
    report), a GIF of the snapshots, and ``run.json`` (``about`` plus the world's log)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = save_media(world.frames, world.images, folder)
    summary = {**about, "world_log": list(world.log)}
    written.append(atomic_write(folder / "run.json", json.dumps(summary, indent=2)))
    return written


__all__ = [
    "PyBulletScenario",
    "belief_for",
    "bottom",
    "goal_holds",
    "over",
    "resolve",
    "save_world",
    "scenarios",
    "setup_scene",
    "true_facts",
]
