"""The robot's side of the PyBullet world: static knowledge, believed state, planning problems.

The domain and stream declarations are the kitchen's (``kitchen/domain.pddl`` and
``kitchen/stream.pddl``), shared with the household: only the stream implementations differ.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

import numpy as np

from llmpas.execution.context import Belief
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.worlds.kitchen.belief import pose_of, rests_at
from llmpas.worlds.kitchen.kitchen_problem import kitchen_problem, start_belief
from llmpas.worlds.pybullet.pybullet_streams import DEFAULT_DEFERRED, Geometry, make_streams
from llmpas.worlds.pybullet.pybullet_values import BaseConf, ObjectPose
from llmpas.worlds.pybullet.scene import SceneConfig


def static_facts(config: SceneConfig) -> set[Atom]:
    """What the robot knows that does not change: tables, bowls (one object each), objects."""
    facts: set[Atom] = set()
    tables = [t.name for t in config.tables]
    bowls = [o.name for o in config.objects if o.kind == "bowl"]
    for t in tables:
        facts |= {Atom.of("Region", t), Atom.of("Surface", t)}
    for b in bowls:
        facts |= {Atom.of("Region", b), Atom.of("Single", b)}
    for o in config.objects:
        facts.add(Atom.of("Object", o.name))
        facts |= {Atom.of("Stackable", o.name, t) for t in tables}
        if o.kind == "cube":
            facts |= {Atom.of("Stackable", o.name, b) for b in bowls}
    return facts


def believe_at(belief: Belief, obj: str, pose: ObjectPose | None) -> None:
    """Believe ``obj`` rests at ``pose`` (None: its whereabouts are unknown)."""
    rests_at(belief, obj, pose)


def believed_pose(belief: Belief, obj: str) -> ObjectPose | None:
    return pose_of(belief, obj, ObjectPose)


def believed_base(belief: Belief) -> BaseConf | None:
    for a in belief.facts:
        if a.predicate == "atbconf":
            value = belief.values.get(a.args[0])
            return value if isinstance(value, BaseConf) else None
    return None


def believe_base(belief: Belief, here: BaseConf) -> None:
    """Believe the base is at ``here`` (where odometry or TF says, after a failed subtree drove
    around): the believed base configuration replaced, unless it is already there."""
    old = belief.matching("atbconf")
    current = belief.values.get(old[0].args[0]) if old else None
    if isinstance(current, BaseConf) and current.distance(here) < 1e-6:
        return
    belief.facts -= set(old)
    q = belief.name("q", here)
    belief.facts |= {Atom("bconf", (q,)), Atom("atbconf", (q,))}


def initial_belief(
    config: SceneConfig, poses: Mapping[str, ObjectPose | None], base: BaseConf
) -> Belief:
    return start_belief(static_facts(config), poses, base)


def make_problem(
    geometry: Geometry,
    belief: Belief,
    goal: Formula | str,
    deferred: Collection[str] = DEFAULT_DEFERRED,
    here: BaseConf | None = None,
) -> Problem:
    streams = make_streams(
        geometry,
        lambda o: believed_pose(belief, o),
        lambda: believed_base(belief) or here,
        deferred,
    )
    return kitchen_problem(set(belief.facts), belief, goal, streams, "pybullet")


def seeded(seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([seed, stream])
