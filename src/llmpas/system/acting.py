"""Planning and acting for the loop: :func:`plan` a goal from the session's belief (with counted
limits, :func:`counted`), :func:`execute` a plan as the world's conditional subtrees, and
:class:`Acting`, which does both for the rounds of one run (plans memoised per round, the time
spent counted, the facts every check reads)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from llmpas.execution.context import Recorder
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode, OnTick, Tick
from llmpas.execution.executor import execute as execute_specs
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig, PlanResult, solve
from llmpas.system.observe import Observer
from llmpas.system.records import Round
from llmpas.worlds.api import Session


def plan(session: Session, goal: Formula | str, index: int) -> tuple[PlanResult, Problem]:
    """Plan ``goal`` from the session's current belief (round ``index``)."""
    problem = session.problem(goal, index)
    return solve(problem, counted(session.planner)), problem


def counted(config: PlannerConfig) -> PlannerConfig:
    """The world's planner with counted limits, so that a verdict (a goal reachable or not) is
    the same on any machine and recorded answers replay exactly; its time limits stay, as
    safety nets (their expiry is ``timeout``, never ``unsolvable``)."""
    if config.deterministic:
        return config
    preset = PlannerConfig.validation()
    return replace(
        config,
        max_stream_calls=preset.max_stream_calls,
        max_empty_samples=preset.max_empty_samples,
    )


def execute(
    session: Session, result: PlanResult, problem: Problem, on_tick: OnTick | None = None
) -> tuple[tuple[SubtreeSpec, ...], Episode | None]:
    """Execute a plan found by :func:`plan` as the world's conditional subtrees (None: there is
    no plan). Each episode gets its own timeline; ``on_tick`` gets the tree after every tick."""
    if result.plan is None:
        return (), None
    specs = tuple(session.decompose(problem, result.plan))
    session.context.recorder = Recorder()
    return specs, execute_specs(specs, session.context, session.executor, on_tick)


@dataclass
class Acting:
    """Plans and executes for the rounds of one run; ``index``: the round being made;
    ``observer``: told of each executed plan, tick and round (None: nobody watches)."""

    session: Session
    index: Callable[[], int]
    observer: Observer | None = None
    plans: dict[tuple[str, int], tuple[PlanResult, Any]] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    statuses: dict[str, int] = field(default_factory=dict)  # how each plan made ended

    def plan(self, goal: Formula | str) -> tuple[PlanResult, Any]:
        """Plan from the current belief (memoised per round: a goal tried for feasibility is
        not planned again when it is then executed)."""
        key = (str(goal), self.index())
        if key not in self.plans:
            t = time.perf_counter()
            self.plans[key] = plan(self.session, goal, self.index())
            self.count("plan", time.perf_counter() - t)
            status = self.plans[key][0].status.value
            self.statuses[status] = self.statuses.get(status, 0) + 1
        return self.plans[key]

    def facts(self, goal: Formula) -> frozenset[Atom]:
        """The facts the planner would plan ``goal`` from now: the belief and what problem
        construction adds (blocking and capacity facts, say). Every check of a goal reads these,
        so that a check and the planner never disagree."""
        return self.session.problem(goal, self.index()).init

    def count(self, what: str, seconds: float) -> None:
        self.timings[what] = self.timings.get(what, 0.0) + seconds

    def attempt(self, goal: Formula | str, text: str) -> Round:
        """Plan ``goal`` and execute the plan: one round."""
        result, problem = self.plan(goal)
        seen, index = self.observer, self.index()
        on_tick = None
        if seen is not None:
            seen.planned(index, text, result)

            def on_tick(tick: Tick) -> None:
                seen.ticked(index, tick)

        t = time.perf_counter()
        specs, episode = execute(self.session, result, problem, on_tick)
        if episode is not None:
            self.count("execute", time.perf_counter() - t)
        rnd = Round(text, result, episode, specs=specs)
        if seen is not None:
            seen.executed(index, rnd)
        return rnd


__all__ = ["Acting", "counted", "execute", "plan"]
