"""The tabletop world's scenes, scenarios and reasoner tables (data only, no physics client).

The seed paper's real-world experiment: a Franka Panda fixed at one table puts a green cube into
a bowl. In ``tabletop-blocking`` the bowl already holds a black cube the robot does not know
about, and a bowl holds one object (action blocking).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from llmpas.reasoning.tables import PromptTables
from llmpas.worlds.pybullet.pybullet_reasoning import PROGRAM_CALLS, vocabulary
from llmpas.worlds.pybullet.scene import ObjectConfig, Rect, SceneConfig, TableConfig

TABLE = "table"
# The robot stands at the table's -y side facing it; the arm reaches this band of the top.
BASE = (0.0, -0.95, math.pi / 2)
WORKSPACE = Rect(-0.45, -0.42, 0.45, -0.18)


@dataclass(frozen=True)
class TabletopScenario:
    """A scene, the task (objects to rest on regions), and what the robot is not told:
    ``inside`` (object, bowl) pairs start in the bowl; ``unknown`` objects are not believed
    anywhere."""

    name: str
    description: str
    scene: SceneConfig
    task: tuple[tuple[str, str], ...]
    seed: int = 0
    inside: tuple[tuple[str, str], ...] = ()
    unknown: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        names = {o.name for o in self.scene.objects} | {t.name for t in self.scene.tables}
        mentioned = {n for pair in (*self.task, *self.inside) for n in pair} | set(self.unknown)
        if not self.task or not mentioned <= names:
            raise ValueError(f"scenario {self.name!r}: unknown names {sorted(mentioned - names)}")
        if self.scene.mount != "pedestal":
            raise ValueError(f"scenario {self.name!r}: the tabletop Panda stands on a pedestal")

    @property
    def goal(self) -> str:
        return "(and " + " ".join(f"(on {o} {r})" for o, r in self.task) + ")"


def scene(*extra: ObjectConfig) -> SceneConfig:
    objects = (
        ObjectConfig("green_cube", "cube", TABLE, -0.15, -0.3, "green"),
        ObjectConfig("bowl", "bowl", TABLE, 0.25, -0.3, "white", 0.16),
        *extra,
    )
    return SceneConfig((TableConfig(TABLE, 0.0, 0.0),), objects, BASE, mount="pedestal")


def scenarios() -> dict[str, TabletopScenario]:
    task = (("green_cube", "bowl"),)
    black = ObjectConfig("black_cube", "cube", TABLE, 0.25, -0.3, "black")
    return {
        s.name: s
        for s in (
            TabletopScenario(
                "tabletop-nominal",
                "A fixed Franka Panda puts the green cube into the empty bowl on its table.",
                scene(),
                task,
            ),
            TabletopScenario(
                "tabletop-blocking",
                "Action blocking: the bowl already holds a black cube the robot does not know "
                "about; a bowl holds one object.",
                scene(black),
                task,
                inside=(("black_cube", "bowl"),),
                unknown=("black_cube",),
            ),
        )
    }


def prompt_tables(config: SceneConfig) -> PromptTables:
    """What the reasoner is told (no example naming this world's objects: it would leak an
    answer; the format example comes from another domain)."""
    return PromptTables(
        actions={
            "pick": (
                "grasp an object on the table or in a bowl (the hand must be empty)",
                ("holding",),
            ),
            "place": (
                "set the held object down on the table or into a bowl (a bowl holds one object)",
                ("on",),
            ),
            "scan_table": ("look at the table with the camera and see what is on it", ("scanned",)),
        },
        predicates={
            "on": ("?o ?r", "object ?o rests on table ?r or inside bowl ?r"),
            "holding": ("?o", "the arm holds object ?o"),
            "scanned": ("?r", "the robot has looked at table ?r"),
        },
        calls=PROGRAM_CALLS,
        objects=tuple(sorted(o.name for o in config.objects)),
    )


__all__ = ["TabletopScenario", "prompt_tables", "scenarios", "vocabulary"]
