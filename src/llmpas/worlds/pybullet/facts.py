"""The state of a PyBullet scene as facts: ``(holding O)``, ``(on O R)`` (an object at rest in a
bowl or on a table). The simulator's scene gives the truth; a planning scene (a robot's model of
the world, kept from what it perceived) gives what the robot perceived."""

from __future__ import annotations

from typing import Any

from llmpas.language.logic import Atom
from llmpas.worlds.api import holds
from llmpas.worlds.pybullet.scene import RIM_MARGIN, Scene


def true_facts(scene: Scene) -> frozenset[Atom]:
    """PyBullet's true state as facts, for the truth judge (:func:`llmpas.worlds.api.holds`):
    ``(holding O)`` for the held object, ``(on O R)`` for an object at rest in region R (inside
    a bowl's rim, its bottom below the rim; else on the table under it). An object over a bowl
    higher up (on its rim, on something in it) is on neither."""
    facts: set[Atom] = set()
    for o in scene.config.objects:
        if scene.held == o.name:
            facts.add(Atom("holding", (o.name,)))
            continue
        at, _ = scene.pose(o.name)
        region = _resting_in(scene, o.name, at)
        if region is not None:
            facts.add(Atom("on", (o.name, region)))
    return frozenset(facts)


def over(scene: Scene, name: str, bowl: str) -> bool:
    """Whether object ``name`` is over the inside of ``bowl`` (in it, or above it)."""
    at, _ = scene.pose(name)
    pos, _ = scene.pose(bowl)
    inner = scene.config.obj(bowl).size / 2 - 0.01
    return bool(abs(at[0] - pos[0]) < inner and abs(at[1] - pos[1]) < inner)


def bottom(scene: Scene, name: str) -> float:
    """The z of an object's bottom (a graspable object's pose is its centre)."""
    o = scene.config.obj(name)
    at, _ = scene.pose(name)
    return float(at[2]) - o.origin_height


def _resting_in(scene: Scene, name: str, at: Any) -> str | None:
    for bowl in scene.config.objects:
        if bowl.kind != "bowl" or bowl.name == name or not over(scene, name, bowl.name):
            continue
        pos, _ = scene.pose(bowl.name)
        rim = float(pos[2]) + bowl.height - RIM_MARGIN
        return bowl.name if bottom(scene, name) < rim else None
    for table, rect in scene.tables.items():
        if rect.contains(float(at[0]), float(at[1])):
            return table
    return None


def goal_holds(scene: Scene, goal: str) -> bool:
    """Judge a goal (``(On cube bowl)``: the cube resting inside) in the true state."""
    return holds(goal, true_facts(scene))


__all__ = ["bottom", "goal_holds", "over", "true_facts"]
