"""What a world supplies to LLM-PAS: parts, never a loop.

A **world** (:class:`World`) is a plug-in found by name (``household``, ``pybullet``,
``tabletop``, or ``mypkg.module:WORLD``). It lists its scenarios and opens a **session**
(:class:`Session`) on one of them. A session supplies

- the domain, the task goal and the problem for a goal from the current belief
  (:meth:`Session.problem`), which the planner solves;
- the decomposition of a plan into conditional subtrees (:meth:`Session.decompose`, a world's
  :class:`~llmpas.execution.plan_builder.PlanBuilder`);
- the robot and its perception, in an execution :class:`~llmpas.execution.context.Context`;
- the reasoner's tables as data (:class:`~llmpas.reasoning.prompts.PromptTables`), the goal
  vocabulary and an environment description from the belief;
- a small search model (:class:`SearchModel`): what "searched", "found" and "where it may be"
  mean in this world.

:mod:`llmpas.system` plans, executes and asks the LLM; a world never does. Nothing here reads a
world's true state except :meth:`Session.achieved` (a judge, afterwards) and a world's oracle,
which lives in the world's folder beside it.

**One folder.** A shipped world is a package under :mod:`llmpas.worlds` whose ``__init__.py``
registers it: a :class:`WorldEntry` named ``WORLD_ENTRY`` (its name, its world and oracle as
``module:ATTR``, where it stands in listings, its scenarios for the command line's help). A
package that serves a simulated robot (``llmpas robot NAME``) registers a :class:`RobotEntry`
named ``ROBOT_ENTRY``. The registry (:mod:`llmpas.system.catalog`) finds them; nothing else
lists them.


**One truth judge.** A session whose world has a true state says so as facts
(:class:`TrueFacts`: ``true_facts()``, in the domain's predicates); the task is then judged on
them by :func:`holds`, the same for every world and for the suite's judge. A session without
one keeps :meth:`Session.achieved` (None: the robot's belief decides).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence, Set
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.context import Context
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import ExecutorConfig
from llmpas.language.domain import Domain
from llmpas.language.logic import And, Atom, Formula, Imply, Not, Or
from llmpas.language.problem import Problem
from llmpas.language.sexpr import SExpr, SList, Sym, parse_all
from llmpas.planning import PlannerConfig
from llmpas.planning.result import Plan
from llmpas.reasoning.tables import PromptTables, Vocabulary


@dataclass(frozen=True)
class WorldEntry:
    """A shipped world's registration (``WORLD_ENTRY`` in its package's ``__init__.py``): light,
    names only, so that the registry reads it without importing the world (nor PyBullet).

    ``world``: ``module:ATTR`` of its :class:`World`; ``oracle``: ``module:ATTR`` of its labelled
    oracle, a function of a session (empty: ``--llm oracle`` is unknown there); ``rank``: where it
    stands when worlds are listed (help, errors), lowest first; ``help``: its scenarios as the
    command line's help says them (empty: not named in the help); ``files``: ``module:ATTR`` of
    a function of a scenario name or ``.toml`` path to that file, for the world that reads
    scenario files (one at most: a ``.toml`` file is its scenario); ``tasks``: ``module:ATTR`` of
    a function of such a file to its scenario and its intent when the file is a judged task
    (else None: ``llmpas run`` runs a judged task as ``llmpas bench prompting`` does);
    ``sites``: it reads a site file (``--site``)."""

    name: str
    world: str
    oracle: str = ""
    rank: int = 100
    help: str = ""
    files: str = ""
    tasks: str = ""
    sites: bool = False

    def __post_init__(self) -> None:
        if not self.name or ":" in self.name:
            raise ValueError(f"a world's name is a word without ':', got {self.name!r}")
        for spec in (self.world, self.oracle or "m:a", self.files or "m:a", self.tasks or "m:a"):
            module, _, attr = spec.partition(":")
            if not module or not attr:
                raise ValueError(f"world {self.name}: expected module:ATTR, got {spec!r}")


@dataclass(frozen=True)
class RobotEntry:
    """A simulated robot's registration (``ROBOT_ENTRY`` in its package's ``__init__.py``):
    ``llmpas robot NAME ARGS`` runs ``command`` (``module:ATTR`` of ``run(argv) -> int``)."""

    name: str
    command: str


@dataclass(frozen=True)
class RunOptions:
    """How a session runs, whatever the world. ``None`` fields: the world's own default."""

    planner: PlannerConfig | None = None
    executor: ExecutorConfig | None = None
    seed: int | None = None  # None: the scenario's own seed
    gui: bool = False  # open the simulator's window, where there is one
    snapshots: bool = True  # keep images where the world makes them
    robot_profile: str | None = None  # a robot's profile (a file or a shipped name), where used
    site: str | None = None  # a site file (places, furniture, told objects, tasks), where used

    def __post_init__(self) -> None:
        if self.planner is not None and not math.isfinite(self.planner.max_time):
            raise ValueError("the planner needs a finite max_time")


@runtime_checkable
class SearchModel(Protocol):
    """What searching means in a world.

    ``predicate``: the goal that looks at a place (``scanned``); ``location``: where an object
    rests (``on``, object first, place second); ``detection``: the constraint name of a failed
    detection (``Detected``)."""

    @property
    def predicate(self) -> str: ...

    @property
    def location(self) -> str: ...

    @property
    def detection(self) -> str: ...

    def places(self) -> tuple[str, ...]:
        """Where the robot can look for an object: the arguments of ``(predicate P)``."""
        ...

    def looked_at(self, report: AnomalyReport) -> tuple[str, ...]:
        """The places a failed detection looked at."""
        ...

    def lost(self, obj: str) -> bool:
        """Whether the robot does not know where ``obj`` is (and does not hold it)."""
        ...


@runtime_checkable
class Session(Protocol):
    """One scenario of a world across planning rounds; its belief carries over."""

    @property
    def name(self) -> str: ...  # the scenario's name

    @property
    def task(self) -> str: ...  # the task goal, as PDDL text

    @property
    def domain(self) -> Domain: ...

    @property
    def context(self) -> Context: ...  # robot, perception, belief and rng

    @property
    def vocabulary(self) -> Vocabulary: ...  # the goal predicates and their arguments

    @property
    def prompts(self) -> PromptTables: ...  # actions, predicates, skill calls, objects

    @property
    def search(self) -> SearchModel: ...

    @property
    def planner(self) -> PlannerConfig: ...

    @property
    def executor(self) -> ExecutorConfig: ...

    def problem(self, goal: Formula | str, index: int) -> Problem:
        """The planning problem for ``goal`` from the current belief, in round ``index``."""
        ...

    def decompose(self, problem: Problem, plan: Plan) -> Sequence[SubtreeSpec]:
        """The plan's conditional subtrees (called once per executed plan)."""
        ...

    def environment(self) -> str:
        """The believed state, as short lines for a prompt."""
        ...

    def achieved(self) -> bool | None:
        """The task judged in the world's true state, afterwards (None: the world has no judge;
        the robot's belief decides)."""
        ...

    def save(self, folder: Path) -> list[Path]:
        """The world's own files for a run folder (snapshots, a GIF, its log)."""
        ...

    @property
    def timings(self) -> Mapping[str, float]: ...  # seconds the world counted (build, ...)


@runtime_checkable
class TrueFacts(Protocol):
    """A session whose world has a true state: it judges the task on it (:func:`holds`)."""

    def true_facts(self) -> frozenset[Atom]:
        """The world's true state now, as ground facts in the domain's predicates (``(on O R)``
        for an object at rest in R, ``(holding O)``, ``(open R)``, an object's states); what is
        not among them is false."""
        ...


@dataclass(frozen=True)
class Shape:
    """A box in a world's scene, for a viewer: a place (``kind`` "place": a table, a room) or
    an object ("object"), centred at ``xyz`` (metres, the world frame), ``size`` its extents,
    turned ``yaw`` about z; ``rgba`` its colour (0..1)."""

    name: str
    kind: str
    xyz: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("a shape needs a name")
        if self.kind not in ("place", "object"):
            raise ValueError(
                f"shape {self.name!r}: kind must be place or object, not {self.kind!r}"
            )
        numbers = (*self.xyz, *self.size, self.yaw, *self.rgba)
        if len(self.xyz) != 3 or len(self.size) != 3 or len(self.rgba) != 4:
            raise ValueError(f"shape {self.name!r}: xyz and size need 3 numbers, rgba 4")
        if not all(math.isfinite(v) for v in numbers) or min(self.size) < 0:
            raise ValueError(f"shape {self.name!r}: finite numbers and sizes >= 0 only")


@dataclass(frozen=True)
class Pose3:
    """A frame of the robot (its base, its gripper) in ``parent``: a translation and a unit
    quaternion (x, y, z, w)."""

    name: str
    parent: str
    xyz: tuple[float, float, float]
    quaternion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if not self.name or not self.parent or self.name == self.parent:
            raise ValueError(f"frame {self.name!r}: needs a name and another parent")
        if len(self.xyz) != 3 or len(self.quaternion) != 4:
            raise ValueError(f"frame {self.name!r}: xyz needs 3 numbers, the quaternion 4")
        if not all(math.isfinite(v) for v in (*self.xyz, *self.quaternion)):
            raise ValueError(f"frame {self.name!r}: finite numbers only")
        if abs(math.hypot(*self.quaternion) - 1.0) > 1e-3:
            raise ValueError(f"frame {self.name!r}: the quaternion is not a unit quaternion")


@dataclass(frozen=True)
class SceneView:
    """What a viewer draws of a world now: its places and the objects where the robot believes
    them (``believed``), the objects where they truly are (``truth``; empty: the world has no
    truth to show) and the robot's frames (``frames``, in the frame ``world``)."""

    believed: tuple[Shape, ...]
    truth: tuple[Shape, ...] = ()
    frames: tuple[Pose3, ...] = ()


@runtime_checkable
class SceneGeometry(Protocol):
    """A session that can say where things are in metres (optional: a session without it is
    drawn from its search model's places and the believed ``location`` facts, as labels)."""

    def scene_view(self) -> SceneView:
        """The scene now (called between ticks, at most a few times a second)."""
        ...


def holds(goal: Formula | str, facts: Set[Atom]) -> bool:
    """Whether ``goal`` holds in ``facts``, read as a closed world (the one truth judge).

    ``goal``: a ground formula of atoms, ``and``, ``or``, ``not`` and ``imply`` (``=``: the
    same name), or its PDDL text (names read in lower case, as the domain reader does).
    ValueError for anything else (a quantifier, a variable)."""
    if isinstance(goal, str):
        goal = _ground(goal)
    if isinstance(goal, Atom):
        if any(a.startswith("?") for a in goal.args):
            raise ValueError(f"{goal}: a truth judge needs ground atoms")
        if goal.predicate == "=" and len(goal.args) == 2:
            return goal.args[0] == goal.args[1]
        return goal in facts
    if isinstance(goal, Not):
        return not holds(goal.arg, facts)
    if isinstance(goal, And):
        return all(holds(p, facts) for p in goal.parts)
    if isinstance(goal, Or):
        return any(holds(p, facts) for p in goal.parts)
    if isinstance(goal, Imply):
        return not holds(goal.cond, facts) or holds(goal.then, facts)
    raise ValueError(f"{goal}: a truth judge reads atoms, and, or, not and imply only")


def _ground(text: str) -> Formula:
    exprs = parse_all(text, "goal")
    if len(exprs) != 1 or not isinstance(exprs[0], SList):
        raise ValueError(f"not one formula: {text!r}")
    return _read(exprs[0])


def _read(e: SExpr) -> Formula:
    if not isinstance(e, SList) or e.head() is None:
        raise ValueError(f"{e}: expected a formula")
    head, items = e.head(), e.items[1:]
    if head == "and":
        return And(tuple(_read(i) for i in items))
    if head == "or":
        return Or(tuple(_read(i) for i in items))
    if head == "not" and len(items) == 1:
        return Not(_read(items[0]))
    if head == "imply" and len(items) == 2:
        return Imply(_read(items[0]), _read(items[1]))
    if head in ("not", "imply", "exists", "forall", "when"):
        raise ValueError(f"{e}: a truth judge reads atoms, and, or, not and imply only")
    if not all(isinstance(a, Sym) for a in items):
        raise ValueError(f"{e}: an atom's arguments are names")
    return Atom(str(head), tuple(str(a) for a in items))


@runtime_checkable
class World(Protocol):
    """A world plug-in: its scenarios and sessions on them."""

    @property
    def name(self) -> str: ...

    @property
    def title(self) -> str: ...  # shown on reports ("PyBullet: Husky + Franka Panda")

    def scenarios(self) -> Mapping[str, str]:
        """Shipped scenario names and one line each."""
        ...

    def open(self, scenario: Any, options: RunOptions) -> AbstractContextManager[Session]:
        """A session on ``scenario`` (a shipped name, a file the world reads, or the world's own
        scenario value); closed on
        exit (a physics client disconnected, say). Unknown names: ``KeyError`` naming the known
        ones; a bad file: an :class:`~llmpas.errors.InputError` naming it."""
        ...


__all__ = [
    "Pose3",
    "RobotEntry",
    "RunOptions",
    "SceneGeometry",
    "SceneView",
    "SearchModel",
    "Session",
    "Shape",
    "TrueFacts",
    "World",
    "WorldEntry",
    "holds",
]
