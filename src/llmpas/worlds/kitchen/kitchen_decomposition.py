"""What the kitchen worlds' plan decompositions share, on top of
:class:`llmpas.execution.plan_builder.PlanBuilder`: the exploration budgets, the recipe table of
the kitchen domain's actions, the base poses to look from, the grasp and base dimensions of a
reach, the precondition check, the grasp skill, the scan and the plain base move. A world
supplies how it drives, looks, picks and places, and the recipes of the actions it has beyond
those (an action it has none for gets :meth:`KitchenBuilder.otherwise`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, Values
from llmpas.execution.plan_builder import BaseMoves, PlanBuilder, Recipe
from llmpas.execution.robot_protocols import SkillResult
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom
from llmpas.planning.result import PlanStep
from llmpas.worlds.kitchen.belief import DETECTION, pose_of, rests_at
from llmpas.worlds.kitchen.kitchen_values import BaseConf, Grasp

OK = SkillResult.success()
BASE = BaseMoves(
    action="move_base",
    fluent="atbconf",
    streams=("inverse-kinematics", "sample-view"),
    dims=("base", "view_base"),
    kind="bconf",
)
ADOPTED = frozenset({"pose", "supported", "grasp"})  # stream facts the belief keeps


@dataclass(frozen=True)
class ExplorationConfig:
    """Budgets of the constraint-space exploration (per subtree)."""

    view_bases: int = 3  # base poses to look from
    grasps: int = 2
    base_samples: int = 3  # base poses to act from, per grasp
    max_samples: int = 40  # values drawn over a whole subtree
    spots: int = 8  # placements sampled when the planned one is taken

    def __post_init__(self) -> None:
        budgets = (self.view_bases, self.grasps, self.base_samples, self.max_samples, self.spots)
        if min(budgets) < 1:
            raise ValueError("exploration budgets must be >= 1")


class KitchenBuilder(PlanBuilder):
    """The shared recipes and pieces (see the module doc)."""

    exploration: ExplorationConfig
    fit_grasp_budget = False  # cap the grasp budget at the number of grasp kinds offered
    base = BASE
    adopted = ADOPTED
    detection = DETECTION

    # ------------------------------------------------------------ what a world supplies
    def pick(self, step: PlanStep) -> Recipe:
        raise NotImplementedError

    def place(self, step: PlanStep) -> Recipe:
        raise NotImplementedError

    def otherwise(self, step: PlanStep) -> Recipe:
        """The recipe of an action the world has no recipe of its own for (the processing
        actions clean, cook, heat, cool and dry always come here)."""
        raise NotImplementedError

    def scan_inside(self, step: PlanStep) -> Recipe:
        """``scan_drawer`` and ``scan_container`` (default: :meth:`otherwise`)."""
        return self.otherwise(step)

    def scan_cover(self, step: PlanStep) -> Recipe:
        """Lift a cover and look under it (default: :meth:`otherwise`)."""
        return self.otherwise(step)

    def open_close(self, step: PlanStep) -> Recipe:
        """``open`` and ``close`` (default: :meth:`otherwise`)."""
        return self.otherwise(step)

    def _go(self, name: str, key: str) -> SubAction:
        """Drive to the base pose of dimension ``key``."""
        raise NotImplementedError

    def _look(self, region: Callable[[Values, Context], str]) -> SubAction:
        """Look at the region and update the belief from what is seen."""
        raise NotImplementedError

    # ------------------------------------------------------------ the shared part
    @property
    def max_samples(self) -> int:
        return self.exploration.max_samples

    def forget_object(self, belief: Belief, obj: str, place: str | None) -> None:
        """Forget where ``obj`` rests only when the belief still has it at ``place`` (the
        same piece of furniture, :meth:`same_place`): a look that saw it elsewhere during the
        search is kept."""
        at = pose_of(belief, obj, object)
        region = getattr(at, "region", None)
        if place is None or region is None or self.same_place(belief, region, place):
            rests_at(belief, obj, None)

    def same_place(self, belief: Belief, region: str, place: str) -> bool:
        """Whether an object believed in ``region`` is at the ``place`` a look failed at
        (default: the same name; a world with furniture of several regions says more)."""
        return region == place

    def recipe(self, step: PlanStep) -> Recipe:
        """The recipe of a kitchen-domain action."""
        recipes: dict[str, Callable[[PlanStep], Recipe]] = {
            "pick": self.pick,
            "place": self.place,
            "scan_table": self.scan,
            "scan_drawer": self.scan_inside,
            "scan_container": self.scan_inside,
            "scan_cover": self.scan_cover,
            "open": self.open_close,
            "close": self.open_close,
            "move_base": self.move,
        }
        return recipes.get(step.action, self.otherwise)(step)

    def _check(self, step: PlanStep, *extra: Constraint) -> SubAction:
        """The step's precondition in the believed state (after ``extra`` constraints)."""
        return SubAction("check", lambda v, c: OK, constraints=(*extra, self._precondition(step)))

    def _view_bases(self, region: Callable[[Values], str]) -> Dimension:
        """Base poses facing the region, to look at it from."""

        def sample(v: Values) -> Iterator[BaseConf]:
            yield from self._stream("sample-view", (region(v),))

        return Dimension("view_base", sample, budget=self.exploration.view_bases, describe=str)

    def _reach_dims(
        self, obj: str, where: Callable[[Values], object], kinds: Iterable[str]
    ) -> tuple[Dimension, ...]:
        """The grasp (of ``kinds``), then the base pose to act from on the object at ``where``."""
        grasps = [Grasp(k) for k in kinds]
        budget = self.exploration.grasps
        if self.fit_grasp_budget:
            budget = min(budget, len(grasps))

        def bases(v: Values) -> Iterator[BaseConf]:
            yield from self._stream("inverse-kinematics", (obj, where(v), v["grasp"]))

        return (
            Dimension("grasp", lambda v: grasps, budget=budget, describe=str),
            Dimension("base", bases, budget=self.exploration.base_samples, describe=str),
        )

    def _grasp(self, obj: str, culprits: tuple[str, ...] | None = None) -> SubAction:
        """Close the gripper on ``obj``; a failure is reported as ``(holding obj)``."""
        grasped = Constraint(
            "Grasped",
            lambda v, c: None,
            lambda v: Atom("holding", (obj,)),
            needs=("grasp",),
            culprits=culprits,
        )
        return SubAction(
            "grasp",
            lambda v, c: c.robot.grasp(obj, v["grasp"]),
            needs=("grasp",),
            on_failure=grasped,
        )

    def _scan(self, step: PlanStep, check: SubAction | None = None) -> Recipe:
        """Drive to a base pose facing the region, check the precondition, look at it."""
        region = step.args[0]
        return (self._view_bases(lambda v: region),), (
            self._go("go_look", "view_base"),
            check or self._check(step),
            self._look(lambda v, c: region),
        )

    def scan(self, step: PlanStep) -> Recipe:
        return self._scan(step)

    def move(self, step: PlanStep) -> Recipe:
        """A base move on its own: to the planned base pose."""
        q2 = step.args[1]

        def target(v: Values) -> Iterator[BaseConf]:
            value = self.plan.objects.get(q2) or self.problem.objects.get(q2)
            if isinstance(value, BaseConf):
                yield value

        dims = (Dimension("base", target, budget=1, describe=str),)
        return dims, (self._go("move_base", "base"),)


__all__ = ["OK", "ExplorationConfig", "KitchenBuilder"]
