"""What the reasoner is told about the PyBullet world: its prompt tables (as data), the goal
vocabulary and the believed environment, from the robot's belief and the scene's static
configuration (never the simulator's truth)."""

from __future__ import annotations

from types import MappingProxyType

from llmpas.execution.context import Belief
from llmpas.reasoning.tables import PromptTables, Vocabulary
from llmpas.worlds.kitchen.kitchen_reasoning import CALLS, whereabouts
from llmpas.worlds.pybullet.pybullet_problem import believed_pose
from llmpas.worlds.pybullet.scene import SceneConfig

ACTIONS = {
    "pick": ("pick up an object from a table or a bowl (the hand must be empty)", ("holding",)),
    "place": ("put the held object on a table or into a bowl (one object per bowl)", ("on",)),
    "scan_table": ("drive to a table and look at it, finding what is on it", ("scanned",)),
}
PREDICATES = {
    "on": ("?o ?r", "object ?o rests on table ?r or in bowl ?r"),
    "holding": ("?o", "the robot holds object ?o"),
    "scanned": ("?r", "the robot has looked at table ?r"),
}
PROGRAM_CALLS = MappingProxyType(dict(CALLS))


def vocabulary(config: SceneConfig) -> Vocabulary:
    objects = frozenset(o.name for o in config.objects if o.graspable)
    everything = frozenset(o.name for o in config.objects)
    tables = frozenset(t.name for t in config.tables)
    bowls = frozenset(o.name for o in config.objects if o.kind == "bowl")
    return Vocabulary(
        {"on": (everything, tables | bowls), "holding": (objects,), "scanned": (tables,)}
    )


def environment(config: SceneConfig, belief: Belief) -> str:
    lines = []
    for o in config.objects:
        pose = believed_pose(belief, o.name)
        lines.append(f"- {o.name} ({o.colour} {o.kind}): {whereabouts(belief, o.name, pose)}")
    lines.append(f"- tables: {', '.join(t.name for t in config.tables)}")
    return "\n".join(lines)


def prompt_tables(config: SceneConfig) -> PromptTables:
    # no example naming objects of this world: it would leak an answer
    return PromptTables(
        ACTIONS, PREDICATES, PROGRAM_CALLS, tuple(sorted(o.name for o in config.objects))
    )


__all__ = ["ACTIONS", "PREDICATES", "PROGRAM_CALLS", "environment", "prompt_tables", "vocabulary"]
