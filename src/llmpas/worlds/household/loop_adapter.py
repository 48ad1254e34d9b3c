"""The household world as the closed loop sees it (:class:`llmpas.system.LoopWorld`): one
scenario's simulation, the robot's belief and execution context, planning and execution from
that belief, and the prompt text. What the loop does with it lives in :mod:`llmpas.system`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Belief, Context, Recorder
from llmpas.execution.executor import Episode, execute
from llmpas.language.domain import Domain
from llmpas.language.logic import Formula
from llmpas.planning import PlanResult, solve
from llmpas.reasoning.goals import Vocabulary
from llmpas.reasoning.methods import Situation
from llmpas.worlds.household.decomposition import build_specs
from llmpas.worlds.household.problem import Household, believed_place, load_domain, make_problem
from llmpas.worlds.household.reasoning import situation, vocabulary
from llmpas.worlds.household.run import RunConfig, belief_from, household_for
from llmpas.worlds.household.scenario import Scenario
from llmpas.worlds.household.sim import HouseholdWorld


@dataclass(frozen=True)
class HouseholdLoopWorld:
    """One household scenario across planning rounds (the belief carries over)."""

    scenario: Scenario
    house: Household
    sim: HouseholdWorld  # the simulator: only the oracle may read its truth
    config: RunConfig
    seed: int
    belief: Belief
    ctx: Context
    vocabulary: Vocabulary
    domain: Domain

    @classmethod
    def open(cls, scenario: Scenario, config: RunConfig) -> HouseholdLoopWorld:
        house = household_for(scenario)
        seed = scenario.seed if config.seed is None else config.seed
        sim = HouseholdWorld(house.layout, scenario, np.random.default_rng([seed, 0]))
        belief = belief_from(house, scenario)
        ctx = Context(sim, sim, belief, np.random.default_rng([seed, 2]))
        return cls(
            scenario, house, sim, config, seed, belief, ctx, vocabulary(house), load_domain()
        )

    @property
    def name(self) -> str:
        return self.scenario.name

    @property
    def task(self) -> str:
        return self.scenario.goal

    def plan(self, goal: Formula | str, index: int) -> tuple[PlanResult, Any]:
        rng = np.random.default_rng([self.seed, index, 1])
        problem = make_problem(self.house, self.belief, goal, rng)
        return solve(problem, self.config.planner), problem

    def execute(self, plan: PlanResult, problem: Any) -> Episode | None:
        if plan.plan is None:
            return None
        specs = build_specs(self.house, problem, plan.plan, self.config.exploration)
        self.ctx.recorder = Recorder()  # each round's episode has its own timeline
        return execute(specs, self.ctx, self.config.executor)

    def situation(self, report: AnomalyReport, history: str) -> Situation:
        return situation(self.house, self.belief, report, self.scenario.goal, history)

    def search_places(self) -> tuple[str, ...]:
        return self.house.search_places()

    def looked_at(self, report: AnomalyReport) -> tuple[str, ...]:
        """The places a failed detection looked at: its ``view`` alternatives."""
        return tuple(sorted({v.strip("'") for v in report.explored.get("view", ())}))

    def lost(self, obj: str) -> bool:
        return (
            obj in self.house.objects
            and believed_place(self.belief, obj) is None
            and not self.belief.matching("atgrasp", obj)
        )


__all__ = ["HouseholdLoopWorld"]
