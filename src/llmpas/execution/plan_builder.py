"""What every world's plan -> CSubBT decomposition shares: one subtree per plan step (a base
move merged with the action after it), the step's precondition checked in the believed state, the
PDDL effects applied to the belief on success, and the planned stream values adopted.

A world subclasses :class:`PlanBuilder` and supplies its recipes (dimensions and sub-actions per
action), how many samples a subtree may draw, how it forgets where an object is, and its own words:
how its plans move a mobile base (:class:`BaseMoves`), which stream facts about a produced value
the belief keeps, and which constraint means "not found where believed". Nothing here names a
predicate, an action or a stream of any particular domain.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from llmpas.execution.anomaly_report import Failure
from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec, Values
from llmpas.execution.space import NO_SAMPLE, Dimension
from llmpas.language.logic import Atom, Formula, Not, Substitution, conjuncts, effect_atoms
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics
from llmpas.planning.result import Plan, PlanStep

Recipe = tuple[tuple[Dimension, ...], tuple[SubAction, ...]]


@dataclass(frozen=True)
class BaseMoves:
    """How a world's plans move a mobile base (all empty for a robot without one).

    ``action``: the base move merged into the action after it (when that action is one of the
    builder's ``merged``); ``fluent``: the predicate holding where the base is, which the subtree
    satisfies itself (never checked against the belief); ``streams``: deferred streams whose
    outputs are base poses; ``dims``: the subtree dimensions that hold the base pose the robot
    used (the first one set wins); ``kind``: the unary fact a base pose value gets."""

    action: str | None = None
    fluent: str | None = None
    streams: tuple[str, ...] = ()
    dims: tuple[str, ...] = ()
    kind: str | None = None

    def __post_init__(self) -> None:
        if self.streams and not (self.dims and self.kind):
            raise ValueError("base-pose streams need the dimensions and the fact that hold them")


def failing_literal(
    sem: Semantics,
    belief: Belief,
    step: PlanStep,
    problem: Problem,
    plan: Plan,
    unchecked: frozenset[str] = frozenset(),
) -> Formula | None:
    """The first conjunct of the step's precondition that the believed state makes false.

    Literals over stream-certified predicates (Kin, View, ...) and the ``unchecked`` ones (a
    base pose) are not checked here: the subtree satisfies them itself, with its samplers."""
    action = problem.domain.action(step.action)
    env = dict(zip((p.name for p in action.params), step.args, strict=True))
    handled = set(problem.streams.certified_predicates) | unchecked
    state = sem.state(belief.facts | plan.certified)
    for c in conjuncts(action.precondition):
        inner = c.arg if isinstance(c, Not) else c
        if isinstance(inner, Atom) and inner.predicate in handled:
            continue
        ground = Substitution(env).formula(c)
        if not sem.holds(ground, state):
            return ground
    return None


MERGED_PREFIX = "move-and-"  # a subtree's action when a base move is merged into the step


def planned_action(action: str) -> str:
    """The plan's action a subtree's (possibly merged) action stands for."""
    return action.removeprefix(MERGED_PREFIX)


def shown(args: tuple[str, ...]) -> list[str]:
    """Plan arguments for labels: placeholders of deferred streams are shown as '?'."""
    return [a if not a.startswith("#") else "?" for a in args]


class PlanBuilder:
    """The shared part of a world's plan decomposition (see the module doc)."""

    problem: Problem
    plan: Plan
    sem: Semantics
    merged: tuple[str, ...] = ()  # actions a preceding base move is merged into
    base: BaseMoves = BaseMoves()
    adopted: frozenset[str] = frozenset()  # stream facts about a produced value the belief keeps
    detection: str | None = None  # the constraint whose failure: not where it was believed

    # -------------------------------------------------------------- what a world supplies
    def recipe(self, step: PlanStep) -> Recipe:
        raise NotImplementedError

    @property
    def max_samples(self) -> int:
        raise NotImplementedError

    def forget_object(self, belief: Belief, obj: str, place: str | None) -> None:
        """The object was not found at ``place`` (the failed constraint's place, None when it
        names none): forget where it is if the belief still has it there. A sighting elsewhere
        made by a look of the same subtree is kept (what any look saw stays until a later look
        contradicts it)."""
        raise NotImplementedError

    def after_step(self, step: PlanStep, v: Values, ctx: Context) -> None:
        """A world's own belief update after a step's effects (default: none)."""

    # -------------------------------------------------------------- the shared part
    def specs(self) -> list[SubtreeSpec]:
        steps = list(self.plan.steps)
        out: list[SubtreeSpec] = []
        i = 0
        while i < len(steps):
            merge = (
                self.base.action is not None
                and steps[i].action == self.base.action
                and i + 1 < len(steps)
                and steps[i + 1].action in self.merged
            )
            idx = (i, i + 1) if merge else (i,)
            out.append(self.spec(idx, steps[idx[-1]], merged=merge))
            i += len(idx)
        return out

    def spec(self, idx: tuple[int, ...], step: PlanStep, merged: bool) -> SubtreeSpec:
        dims, subs = self.recipe(step)
        prefix = MERGED_PREFIX if merged else ""
        args = shown(step.args)
        steps = [self.plan.steps[k] for k in idx]
        return SubtreeSpec(
            label=f"{prefix}{step.action} {' '.join(args)}".strip(),
            steps=idx,
            action=prefix + step.action,
            args=tuple(args),
            fixed={},
            dims=dims,
            sub_actions=subs,
            max_samples=self.max_samples,
            on_success=self._effects(steps),
            on_failure=self._forget(step),
            atoms=self._achieves(steps),
        )

    def _achieves(self, steps: list[PlanStep]) -> tuple[Atom, ...]:
        """The ground atoms the steps add (what the subtree is for), for reports and maps."""
        out: list[Atom] = []
        for st in steps:
            action = self.problem.domain.action(st.action)
            sub = Substitution(dict(zip((p.name for p in action.params), st.args, strict=True)))
            out += [sub.atom(a) for add, a in effect_atoms(action.effects) if add]
        return tuple(out)

    def _stream(self, name: str, inputs: tuple[Any, ...]) -> Iterator[Any]:
        """A (deferred) stream of the problem, evaluated now on perceived values."""
        for out in self.problem.bound_streams[name].samples(inputs):
            yield NO_SAMPLE if out is None else out[0]

    def _precondition(self, step: PlanStep) -> Constraint:
        """The step's precondition in the believed state, reported as the literal that fails."""
        last: dict[str, Formula] = {}

        def check(v: Values, ctx: Context) -> str | None:
            lit = failing_literal(
                self.sem, ctx.belief, step, self.problem, self.plan, self.unchecked
            )
            if lit is None:
                return None
            last["lit"] = lit
            return f"{lit} does not hold in what the robot perceives"

        def atom(v: Values) -> Any:
            return last.get("lit", Atom("precondition", (step.action,)))

        return Constraint("Precondition", check, atom)

    @property
    def unchecked(self) -> frozenset[str]:
        """Precondition predicates the subtree satisfies itself (the base pose)."""
        return frozenset() if self.base.fluent is None else frozenset({self.base.fluent})

    def _base_used(self, st: PlanStep, v: Values, ctx: Context) -> None:
        """Base-pose placeholders of deferred streams get the pose the robot actually used."""
        for ref in st.deferred:
            if ref.stream not in self.base.streams or self.base.kind is None:
                continue
            base = next((v[d] for d in self.base.dims if d in v), None)
            ctx.belief.values.update(dict.fromkeys(ref.outputs, base))
            ctx.belief.facts |= {Atom(self.base.kind, (o,)) for o in ref.outputs}

    def _effects(self, steps: list[PlanStep]) -> Callable[[Values, Context], None]:
        """Apply the PDDL effects of the steps to the belief; base placeholders get the pose
        the robot actually used."""

        def apply(v: Values, ctx: Context) -> None:
            for st in steps:
                self._base_used(st, v, ctx)
                self._adopt(st, ctx)
                action = self.problem.domain.action(st.action)
                state = self.sem.state(ctx.belief.facts | self.plan.certified)
                facts, _ = self.sem.apply(action, st.args, state)
                changed = {a.predicate for _, a in effect_atoms(action.effects)}
                keep = {a for a in ctx.belief.facts if a.predicate not in changed}
                ctx.belief.facts = keep | {a for a in facts if a.predicate in changed}
                self.after_step(st, v, ctx)

        return apply

    def _adopt(self, st: PlanStep, ctx: Context) -> None:
        """What planning produced for this step becomes belief: the grasp and the placement
        pose it used (their values and the facts streams certified about them)."""
        for name in st.args:
            value = self.plan.objects.get(name)
            if value is None or name in ctx.belief.values or name in self.problem.objects:
                continue  # only what streams produced
            ctx.belief.values[name] = value
            ctx.belief.facts |= {
                a for a in self.plan.certified if a.predicate in self.adopted and name in a.args
            }

    def _forget_at(self, belief: Belief, obj: str, place: str | None) -> None:
        """:meth:`forget_object` with the place, or without it for a world written before the
        place was passed (``forget_object(belief, obj)``: it forgets the object wherever)."""
        if len(inspect.signature(self.forget_object).parameters) >= 3:
            self.forget_object(belief, obj, place)
        else:
            self.forget_object(belief, obj)  # type: ignore[call-arg]

    def _forget(self, step: PlanStep) -> Callable[[Failure, Context], None]:
        def forget(failure: Failure, ctx: Context) -> None:
            if failure.constraint.name == self.detection and step.args:
                atom = failure.constraint.atom(failure.values)
                args = atom.args if isinstance(atom, Atom) else ()
                place = str(args[1]) if len(args) > 1 else None
                self._forget_at(ctx.belief, step.args[0], place)  # not where it was believed

        return forget


__all__ = [
    "MERGED_PREFIX",
    "BaseMoves",
    "PlanBuilder",
    "Recipe",
    "failing_literal",
    "planned_action",
    "shown",
]
