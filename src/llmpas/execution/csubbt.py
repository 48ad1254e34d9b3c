"""Conditional subtrees (CSubBTs): plan actions as self-adjusting behaviour subtrees.

A CSubBT is built from a :class:`SubtreeSpec` by :func:`build_subtree`::

    Explore "move-and-pick cube"            (decorator: owns the constraint space, backtracks)
    └── Sequence (memory)
        ├── Sequence "locate"                (one atomic sub-action)
        │   ├── Check "Detected?"            (constraint against the current perceived state)
        │   └── Act "look"                   (the robot skill)
        ├── Sequence "pre_approach" ...
        └── ...

Before a sub-action runs, each of its constraints is checked against what the robot perceives now
and the parameters drawn from the constraint space. When a constraint or a skill fails, the
``Explore`` decorator backtracks in the space (resampling the parameters the failure depends on)
and restarts the sequence; only when the space is exhausted does it fail, leaving a structured
:class:`~llmpas.execution.anomaly_report.AnomalyReport` on the blackboard. Nodes follow py_trees'
lifecycle (``initialise``/``update``/``terminate``) and share data through a blackboard namespace
of their own subtree.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import py_trees
from py_trees.common import Access, Status

from llmpas.execution.anomaly_report import AnomalyReport, Failure
from llmpas.execution.context import Context
from llmpas.execution.robot_protocols import Outcome, SkillHandle, as_handle
from llmpas.execution.space import ConstraintSpace, Dimension, Exhausted
from llmpas.language.logic import Atom, Not

log = logging.getLogger(__name__)

Values = Mapping[str, Any]


@dataclass(frozen=True)
class Constraint:
    """A condition checked right before a sub-action runs.

    ``check(values, ctx)`` returns None when satisfied, else a short reason. ``atom(values)`` is
    the constraint as a logical atom for reports (e.g. ``(On cube table1)``). ``needs`` are the
    dimensions it reads; ``culprits`` the ones to resample when it fails (default: ``needs``).
    """

    name: str
    check: Callable[[Values, Context], str | None]
    atom: Callable[[Values], Atom | Not]
    needs: tuple[str, ...] = ()
    culprits: tuple[str, ...] | None = None

    @property
    def resample(self) -> tuple[str, ...]:
        return self.needs if self.culprits is None else self.culprits


@dataclass(frozen=True)
class SubAction:
    """An atomic sub-action: constraints, then a skill. A failed skill counts as a failure of
    ``on_failure`` (its atom and culprits go to the report).

    The skill returns a result or a handle (:mod:`llmpas.execution.robot_protocols`); while it runs,
    every tick polls it and checks the ``guards`` (say: the object to grasp is still seen).
    A guard that fails cancels the skill and fails the sub-action with that guard's reason
    (its culprits are resampled, like a constraint's)."""

    name: str
    skill: Callable[[Values, Context], Outcome]
    constraints: tuple[Constraint, ...] = ()
    needs: tuple[str, ...] = ()
    on_failure: Constraint | None = None
    guards: tuple[Constraint, ...] = ()


@dataclass(frozen=True)
class SubtreeSpec:
    """Everything needed to build one CSubBT for one plan action or a merged run of actions."""

    label: str
    steps: tuple[int, ...]  # plan step indices covered
    action: str  # the (merged) action name, e.g. "move-and-pick"
    args: tuple[str, ...]
    fixed: Mapping[str, Any]
    dims: tuple[Dimension, ...]
    sub_actions: tuple[SubAction, ...]
    max_samples: int = 40
    on_success: Callable[[Values, Context], None] | None = None
    on_failure: Callable[[Failure, Context], None] | None = None  # before the anomaly report
    atoms: tuple[Atom, ...] = field(default_factory=tuple)  # plan atoms this subtree achieves

    def __post_init__(self) -> None:
        if not self.sub_actions:
            raise ValueError(f"subtree {self.label!r} has no sub-actions")
        known = {d.name for d in self.dims}
        for sa in self.sub_actions:
            checked = (*sa.constraints, *sa.guards)
            for n in (*sa.needs, *(x for c in checked for x in c.needs)):
                if n not in known:
                    raise ValueError(
                        f"subtree {self.label!r}: {sa.name} needs unknown dimension {n!r}"
                    )


class _Node(py_trees.behaviour.Behaviour):
    """Common blackboard access: the subtree's space, failure slot and context."""

    def __init__(self, name: str, namespace: str) -> None:
        super().__init__(name=name)
        self.bb = self.attach_blackboard_client(name=name, namespace=namespace)
        for key in ("space", "failure", "context", "spec"):
            self.bb.register_key(key, access=Access.WRITE)

    @property
    def space(self) -> ConstraintSpace:
        return self.bb.space

    @property
    def ctx(self) -> Context:
        return self.bb.context

    def fail(self, failure: Failure) -> Status:
        self.bb.failure = failure
        self.ctx.recorder.event(self.name, "failure", failure.reason, self.space.values())
        return Status.FAILURE


class Check(_Node):
    def __init__(self, constraint: Constraint, sub_action: str, namespace: str) -> None:
        super().__init__(f"{constraint.name}?", namespace)
        self.constraint = constraint
        self.sub_action = sub_action

    def update(self) -> Status:
        c = self.constraint
        try:
            values = self.space.ensure(c.needs)
        except Exhausted as e:
            return self.fail(Failure(self.sub_action, c, f"no value left for {e}", {}, True))
        reason = c.check(values, self.ctx)
        if reason is None:
            return Status.SUCCESS
        return self.fail(Failure(self.sub_action, c, reason, dict(values)))


class Act(_Node):
    """Starts the skill (``initialise``), polls it every tick while it runs (``update``:
    RUNNING), checking the guards, and cancels it when the tree stops it (``terminate``)."""

    def __init__(self, sub_action: SubAction, namespace: str) -> None:
        super().__init__(sub_action.name, namespace)
        self.sub_action = sub_action
        self.handle: SkillHandle | None = None
        self.values: Values = {}
        self.early: Failure | None = None

    def initialise(self) -> None:
        sa = self.sub_action
        self.handle, self.values, self.early = None, {}, None
        try:
            self.values = self.space.ensure(sa.needs)
        except Exhausted as e:
            c = sa.on_failure or _skill_constraint(sa)
            self.early = Failure(sa.name, c, f"no value left for {e}", {}, True)
            return
        self.handle = as_handle(sa.skill(self.values, self.ctx))

    def update(self) -> Status:
        sa = self.sub_action
        if self.early is not None or self.handle is None:
            early = self.early or Failure(sa.name, _skill_constraint(sa), "not started", {})
            return self.fail(early)
        result = self.handle.poll()
        if result.running:
            self.ctx.polls += 1
            return self._guard()
        self.handle = None
        self.ctx.recorder.event(self.name, result.status.value, result.message, self.values)
        if result.ok:
            return Status.SUCCESS
        return self.fail(
            Failure(
                sa.name, sa.on_failure or _skill_constraint(sa), result.message, dict(self.values)
            )
        )

    def _guard(self) -> Status:
        """RUNNING, or FAILURE when a guard fails (the skill is cancelled first)."""
        for guard in self.sub_action.guards:
            reason = guard.check(self.values, self.ctx)
            if reason is not None:
                self._cancel(f"{guard.name}: {reason}")
                return self.fail(Failure(self.sub_action.name, guard, reason, dict(self.values)))
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if self.handle is not None:  # stopped while the skill runs (preempted, Ctrl-C)
            self._cancel(f"stopped ({new_status.value})")

    def _cancel(self, why: str) -> None:
        handle, self.handle = self.handle, None
        if handle is not None:
            handle.cancel()
            self.ctx.recorder.event(self.name, "cancelled", why, self.values)


def _skill_constraint(sa: SubAction) -> Constraint:
    return Constraint(
        f"{sa.name}-succeeds", lambda v, c: None, lambda v: Atom(sa.name, ()), needs=sa.needs
    )


class Explore(py_trees.decorators.Decorator):
    """Runs its child; on failure backtracks in the constraint space and runs it again; fails
    with an anomaly report only when the space is exhausted."""

    def __init__(
        self, spec: SubtreeSpec, child: py_trees.behaviour.Behaviour, namespace: str, ctx: Context
    ) -> None:
        super().__init__(name=spec.label, child=child)
        self.spec = spec
        self.bb = self.attach_blackboard_client(name=spec.label, namespace=namespace)
        for key in ("space", "failure", "context", "spec", "report"):
            self.bb.register_key(key, access=Access.WRITE)
        self.bb.context = ctx
        self.bb.spec = spec
        self.bb.failure = None
        self.bb.report = None
        self.failures: list[Failure] = []
        self._new_space()

    def _new_space(self) -> None:
        self.bb.space = ConstraintSpace(
            self.spec.dims, dict(self.spec.fixed), self.spec.max_samples
        )

    def initialise(self) -> None:
        self.failures = []
        self.bb.report = None
        self._new_space()
        self.bb.context.space = self.bb.space

    def update(self) -> Status:
        status = self.decorated.status
        if status is Status.SUCCESS:
            if self.spec.on_success is not None:
                self.spec.on_success(self.bb.space.values(), self.bb.context)
            return Status.SUCCESS
        if status is Status.RUNNING:
            return Status.RUNNING
        failure: Failure = self.bb.failure
        self.failures.append(failure)
        space: ConstraintSpace = self.bb.space
        if not failure.exhausted and space.backtrack(failure.constraint.resample):
            self.bb.context.recorder.event(self.name, "backtrack", failure.reason, space.values())
            self.decorated.stop(Status.INVALID)  # restart the sequence with the new values
            return Status.RUNNING
        if self.spec.on_failure is not None:
            self.spec.on_failure(failure, self.bb.context)
        self.bb.report = AnomalyReport.build(
            self.spec, failure, self.failures, space, self.bb.context
        )
        self.bb.context.recorder.event(self.name, "anomaly", failure.reason, space.values())
        return Status.FAILURE


def build_subtree(spec: SubtreeSpec, ctx: Context, key: str) -> Explore:
    """The CSubBT of ``spec``; its nodes share blackboard namespace ``/csubbt/<key>``."""
    ns = f"/csubbt/{key}"
    parts = []
    for sa in spec.sub_actions:
        nodes: list[py_trees.behaviour.Behaviour] = [Check(c, sa.name, ns) for c in sa.constraints]
        nodes.append(Act(sa, ns))
        parts.append(py_trees.composites.Sequence(sa.name, memory=True, children=nodes))
    body = py_trees.composites.Sequence(f"{spec.label} steps", memory=True, children=parts)
    return Explore(spec, body, ns, ctx)
