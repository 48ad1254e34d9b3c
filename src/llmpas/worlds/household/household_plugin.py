"""The household world as a plug-in (:class:`llmpas.worlds.api.World`): shipped scenarios (or a
TOML file), and a session per scenario holding the simulator, the robot's belief and execution
context, and the parts the loop asks for. Planning, execution and reasoning live in
:mod:`llmpas.system`."""

from __future__ import annotations

import logging
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import ExecutorConfig
from llmpas.language.domain import Domain
from llmpas.language.logic import Atom, Formula
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig
from llmpas.planning.result import Plan
from llmpas.reasoning.tables import PromptTables, Vocabulary
from llmpas.worlds.api import RunOptions, holds
from llmpas.worlds.household.household_decomposition import ExplorationConfig, build_specs
from llmpas.worlds.household.household_problem import (
    Household,
    initial_belief,
    load_domain,
    make_problem,
)
from llmpas.worlds.household.household_reasoning import environment, prompt_tables, vocabulary
from llmpas.worlds.household.household_values import Placement
from llmpas.worlds.household.layout import Layout
from llmpas.worlds.household.scenario import Scenario, load_scenario
from llmpas.worlds.household.sim import HouseholdWorld
from llmpas.worlds.household.state import true_facts
from llmpas.worlds.kitchen.kitchen_session import PLANNER, KitchenSearch, KitchenSession

log = logging.getLogger(__name__)
SCENARIOS = Path(__file__).parent / "scenarios"


def scenario_path(name: str) -> Path:
    """A shipped scenario by name (``object-loss-table``), or a path to a TOML file."""
    path = Path(name)
    if path.suffix == ".toml" or path.exists():
        return path
    shipped = SCENARIOS / f"{name}.toml"
    if not shipped.exists():
        known = ", ".join(sorted(p.stem for p in SCENARIOS.glob("*.toml")))
        raise FileNotFoundError(f"no scenario {name!r}; shipped scenarios: {known}")
    return shipped


def belief_from(house: Household, scenario: Scenario) -> Belief:
    """The robot's belief at the start, from the scenario's [belief] section."""
    places = {b.name: b.placement for b in scenario.belief.objects}
    props = {b.name: b.properties for b in scenario.belief.objects if b.properties}
    opened = [r for r, is_open in scenario.belief.open.items() if is_open]
    known = scenario.belief
    return initial_belief(
        house, places, scenario.robot, opened, props, known.searched, known.jammed
    )


def household_for(scenario: Scenario, layout: Layout | None = None) -> Household:
    """The robot's static knowledge of the scenario's house (its layout: with a floor if the
    scenario has one)."""
    return Household(layout or scenario.layout, dict(scenario.specs))


def household_search(house: Household, belief: Belief) -> KitchenSearch:
    """Searching in the household: look at a table region, into a drawer, a closed container,
    under a cover; a failed detection looked at its ``view`` alternatives."""

    def looked_at(report: AnomalyReport) -> tuple[str, ...]:
        return tuple(sorted({v.strip("'") for v in report.explored.get("view", ())}))

    places = house.search_places(containers=True)
    return KitchenSearch(belief, places, frozenset(house.objects), Placement, looked_at)


@dataclass(frozen=True)
class HouseholdSession(KitchenSession):
    """One household scenario across planning rounds (the belief carries over)."""

    scenario: Scenario
    house: Household
    sim: HouseholdWorld  # the simulator: only a labelled oracle and the truth judge read it
    seed: int
    context: Context
    planner: PlannerConfig
    executor: ExecutorConfig
    exploration: ExplorationConfig
    domain: Domain = field(default_factory=load_domain)
    timings: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def open(
        cls, scenario: Scenario, options: RunOptions, exploration: ExplorationConfig
    ) -> HouseholdSession:
        house = household_for(scenario)
        seed = scenario.seed if options.seed is None else options.seed
        sim = HouseholdWorld(house.layout, scenario, np.random.default_rng([seed, 0]))
        belief = belief_from(house, scenario)
        ctx = Context(sim, sim, belief, np.random.default_rng([seed, 2]))
        planner = options.planner or PLANNER
        executor = options.executor or ExecutorConfig()
        return cls(scenario, house, sim, seed, ctx, planner, executor, exploration)

    @property
    def vocabulary(self) -> Vocabulary:
        return vocabulary(self.house)

    @property
    def prompts(self) -> PromptTables:
        return prompt_tables(self.house)

    @property
    def search(self) -> KitchenSearch:
        return household_search(self.house, self.belief)

    def problem(self, goal: Formula | str, index: int) -> Problem:
        rng = np.random.default_rng([self.seed, index, 1])
        return make_problem(self.house, self.belief, goal, rng)

    def decompose(self, problem: Problem, plan: Plan) -> Sequence[SubtreeSpec]:
        return build_specs(self.house, problem, plan, self.exploration)

    def environment(self) -> str:
        return environment(self.house, self.belief)

    def true_facts(self) -> frozenset[Atom]:
        """The simulator's hidden true state, as facts (for the truth judge only)."""
        return true_facts(self.sim.truth)

    def achieved(self) -> bool:
        """The task judged in the simulator's true state (a lookalike carried is not done)."""
        return holds(self.task, self.true_facts())

    def save(self, folder: Path) -> list[Path]:
        return []


@dataclass(frozen=True)
class HouseholdPlugin:
    """The household world: a kitchen with a hidden true state (``exploration``: how its
    subtrees explore their constraint spaces)."""

    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    name: str = "household"
    title: str = "household"

    def scenarios(self) -> dict[str, str]:
        return {p.stem: "" for p in sorted(SCENARIOS.glob("*.toml"))}

    @contextmanager
    def open(self, scenario: Any, options: RunOptions) -> Iterator[HouseholdSession]:
        """``scenario``: a :class:`Scenario`, a shipped name or a TOML file."""
        if not isinstance(scenario, Scenario):
            scenario = load_scenario(scenario_path(str(scenario)))
        if options.gui:
            log.warning("the household world has no window: gui ignored")
        yield HouseholdSession.open(scenario, options, self.exploration)


WORLD = HouseholdPlugin()

__all__ = [
    "WORLD",
    "HouseholdPlugin",
    "HouseholdSession",
    "belief_from",
    "household_for",
    "household_search",
    "scenario_path",
]
