"""A tree that keeps ticking while a skill runs: the skill-handle protocol against a tiny
in-memory handle (a goal that runs for a number of polls), guards that preempt it, and Ctrl-C,
which cancels it. Counts, never times."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import py_trees
import pytest

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec
from llmpas.execution.executor import ExecStatus, ExecutorConfig, execute
from llmpas.execution.robot_protocols import (
    Completed,
    SkillHandle,
    SkillResult,
    SkillStatus,
    as_handle,
    finish,
)
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom

from .toy import ToyWorld


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


@dataclass
class Goal:
    """An in-memory goal: RUNNING for ``polls`` polls, then ``result``; cancellable."""

    target: Any
    polls: int
    result: SkillResult = field(default_factory=lambda: SkillResult.success("arrived"))
    polled: int = 0
    cancelled: int = 0
    interrupt_at: int | None = None  # raise KeyboardInterrupt at that poll (a Ctrl-C)

    def poll(self) -> SkillResult:
        self.polled += 1
        if self.interrupt_at is not None and self.polled == self.interrupt_at:
            raise KeyboardInterrupt
        if self.cancelled:
            return SkillResult.failure("cancelled", reason="cancelled")
        if self.polled <= self.polls:
            return SkillResult.still_running(f"driving to {self.target}")
        return self.result

    def cancel(self) -> None:
        self.cancelled += 1


@dataclass
class Base:
    """A robot base whose every drive is a :class:`Goal` of ``polls`` polls."""

    polls: int
    goals: list[Goal] = field(default_factory=list)
    interrupt_at: int | None = None

    def move_base(self, conf: Any) -> Goal:
        goal = Goal(conf, self.polls, interrupt_at=self.interrupt_at)
        self.goals.append(goal)
        return goal


def drive(base: Base, *guards: Constraint, bases: tuple[str, ...] = ("q1", "q2")) -> SubtreeSpec:
    dims = (Dimension("base", lambda v: list(bases), budget=len(bases)),)
    sub = SubAction(
        "move_base",
        lambda v, c: base.move_base(v["base"]),
        needs=("base",),
        guards=guards,
    )
    return SubtreeSpec("drive", (0,), "move", (), {}, dims, (sub,))


def context() -> Context:
    world = ToyWorld("t1a")
    return Context(world, world, Belief([], {}), np.random.default_rng(0))


def test_a_plain_result_is_a_completed_handle() -> None:
    done = as_handle(SkillResult.success("ok"))
    assert isinstance(done, SkillHandle) and isinstance(done, Completed)
    assert done.poll().ok and done.poll().status is SkillStatus.SUCCESS
    done.cancel()  # nothing to stop
    assert done.poll().ok
    with pytest.raises(ValueError):
        Completed(SkillResult.still_running())
    with pytest.raises(TypeError):
        as_handle("arrived")  # type: ignore[arg-type]
    goal = Goal("q1", 3)
    assert as_handle(goal) is goal and finish(goal).ok and goal.polled == 4


def test_the_tree_ticks_while_a_goal_runs_and_polls_it_every_tick() -> None:
    base = Base(polls=12)
    ctx = context()
    ep = execute([drive(base)], ctx, ExecutorConfig(period=0.0, max_ticks=5))
    assert ep.status is ExecStatus.SUCCESS
    assert len(base.goals) == 1 and base.goals[0].polled == 13  # sent once, polled each tick
    assert ep.ticks == 13  # waiting ticks do not spend the tick budget (max_ticks=5)
    assert base.goals[0].cancelled == 0
    assert [e.status for e in ep.events if e.node == "move_base"] == ["success"]


def test_a_guard_preempts_the_running_goal_and_the_subtree_explores() -> None:
    checks: list[str] = []

    def still_seen(v: Any, c: Context) -> str | None:  # the target is lost on the 4th check
        checks.append(v["base"])
        return "the cube is no longer seen" if len(checks) == 4 else None

    seen = Constraint("Seen", still_seen, lambda v: Atom("seen", ("cube",)), needs=("base",))
    base = Base(polls=6)
    ep = execute([drive(base, seen)], context(), ExecutorConfig(period=0.0))
    assert ep.status is ExecStatus.SUCCESS
    first, second = base.goals
    assert (first.target, second.target) == ("q1", "q2")  # backtracked to the next base
    assert first.cancelled == 1 and second.cancelled == 0
    assert first.polled == 4  # ticked while it ran, until the guard failed
    statuses = [(e.node, e.status) for e in ep.events]
    assert ("move_base", "cancelled") in statuses and ("drive", "backtrack") in statuses
    assert any(e.message == "the cube is no longer seen" for e in ep.events)


def test_a_guard_that_keeps_failing_ends_in_an_anomaly_naming_it() -> None:
    seen = Constraint(
        "Seen", lambda v, c: "the cube is no longer seen", lambda v: Atom("seen", ("cube",))
    )
    base = Base(polls=50)
    ep = execute([drive(base, seen)], context(), ExecutorConfig(period=0.0))
    assert ep.status is ExecStatus.ANOMALY
    assert ep.anomaly is not None and ep.anomaly.constraint == Atom("seen", ("cube",))
    assert [g.cancelled for g in base.goals] == [1, 1]


def test_ctrl_c_cancels_the_running_goal() -> None:
    base = Base(polls=100, interrupt_at=5)
    with pytest.raises(KeyboardInterrupt):
        execute([drive(base)], context(), ExecutorConfig(period=0.0))
    assert len(base.goals) == 1 and base.goals[0].cancelled == 1


def test_waiting_is_bounded_too() -> None:
    base = Base(polls=10_000)
    ep = execute([drive(base)], context(), ExecutorConfig(period=0.0, max_waits=20))
    assert ep.status is ExecStatus.BUDGET
    assert base.goals[0].cancelled == 1  # the tree was stopped: the goal too


def test_period_must_be_sane() -> None:
    with pytest.raises(ValueError):
        ExecutorConfig(period=-1.0)
    with pytest.raises(ValueError):
        ExecutorConfig(max_waits=0)
