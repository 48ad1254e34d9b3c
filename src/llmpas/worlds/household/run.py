"""Plan and execute a household scenario without any LLM: belief -> problem -> plan -> CSubBTs ->
episode. The simulator's true state is used only to build the world and to judge afterwards."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode, ExecutorConfig, execute
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig, PlanResult, solve
from llmpas.worlds.household.decomposition import ExplorationConfig, build_specs
from llmpas.worlds.household.layout import Layout, kitchen
from llmpas.worlds.household.problem import Household, initial_belief, make_problem
from llmpas.worlds.household.scenario import Scenario, load_scenario
from llmpas.worlds.household.sim import HouseholdWorld

SCENARIOS = Path(__file__).parent / "scenarios"


@dataclass(frozen=True)
class RunConfig:
    planner: PlannerConfig = field(default_factory=lambda: PlannerConfig(max_time=60.0))
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    executor: ExecutorConfig = field(default_factory=ExecutorConfig)
    seed: int | None = None  # None: the scenario's own seed


@dataclass(frozen=True)
class HouseholdRun:
    """What happened: the plan, its subtrees, the episode (None when planning failed)."""

    scenario: Scenario
    plan: PlanResult
    specs: tuple[SubtreeSpec, ...]
    episode: Episode | None
    world: HouseholdWorld = field(repr=False)
    problem: Problem = field(repr=False)

    @property
    def succeeded(self) -> bool:
        return self.episode is not None and self.episode.succeeded


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
    return initial_belief(house, places, scenario.robot, opened, props)


def household_for(scenario: Scenario, layout: Layout | None = None) -> Household:
    return Household(layout or kitchen(), dict(scenario.specs))


def run_scenario(scenario: Scenario | str | Path, config: RunConfig | None = None) -> HouseholdRun:
    config = config or RunConfig()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario_path(str(scenario)))
    seed = scenario.seed if config.seed is None else config.seed
    house = household_for(scenario)
    world = HouseholdWorld(house.layout, scenario, np.random.default_rng([seed, 0]))
    belief = belief_from(house, scenario)
    rng = np.random.default_rng([seed, 1])
    problem = make_problem(house, belief, scenario.goal, rng)
    result = solve(problem, config.planner)
    if result.plan is None:
        return HouseholdRun(scenario, result, (), None, world, problem)
    specs = tuple(build_specs(house, problem, result.plan, config.exploration))
    ctx = Context(world, world, belief, np.random.default_rng([seed, 2]))
    episode = execute(specs, ctx, config.executor)
    return HouseholdRun(scenario, result, specs, episode, world, problem)
