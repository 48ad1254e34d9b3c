"""The closed loop of LLM-PAS: plan -> execute -> on an anomaly, reason -> validate -> replan from
the believed state with the new goals (and the task goals when they can be planned together) ->
resume, for a bounded number of rounds.

The belief carries over between rounds (what the robot saw while recovering is what lets it
finish the task); the world's truth is never read, except by the labelled oracle.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Context, Recorder
from llmpas.execution.executor import Episode, execute
from llmpas.files import atomic_write
from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.problem import parse_formula
from llmpas.language.semantics import Semantics
from llmpas.planning import PlanResult, solve
from llmpas.reasoning.goals import GoalParse, GoalStatus
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import MethodConfig, Proposal, propose, rejected
from llmpas.worlds.household.decomposition import build_specs
from llmpas.worlds.household.problem import Household, load_domain, make_problem
from llmpas.worlds.household.reasoning import Oracle, situation, vocabulary
from llmpas.worlds.household.run import RunConfig, belief_from, household_for, scenario_path
from llmpas.worlds.household.scenario import Scenario, load_scenario
from llmpas.worlds.household.sim import HouseholdWorld


@dataclass(frozen=True)
class LoopConfig:
    method: MethodConfig = field(default_factory=MethodConfig)
    max_rounds: int = 3  # LLM consultations at most
    run: RunConfig = field(default_factory=RunConfig)

    def __post_init__(self) -> None:
        if self.max_rounds < 0:
            raise ValueError(f"max_rounds must be >= 0, got {self.max_rounds}")


@dataclass(frozen=True)
class Round:
    """One plan-and-execute round, and the LLM's answer to its anomaly (if any)."""

    goal: str
    plan: PlanResult
    episode: Episode | None
    proposal: Proposal | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "goal": self.goal,
            "plan": self.plan.to_json(),
            "episode": self.episode.to_json() if self.episode else None,
        }
        if self.proposal is not None:
            p = self.proposal
            out["reasoning"] = {
                "method": p.method,
                "status": p.parse.status.value,
                "goals": [str(g) for g in p.goals],
                "errors": list(p.parse.errors),
                "repairs": p.repairs,
                "first_look": p.first_look,
                "tokens": p.tokens,
                "latency": p.latency,
                "exchanges": [
                    {
                        "tag": e.tag,
                        "messages": [[m.role, m.content] for m in e.request.messages],
                        "response": e.response.text,
                        "model": e.response.model,
                        "prompt_tokens": e.response.prompt_tokens,
                        "completion_tokens": e.response.completion_tokens,
                        "latency": e.response.latency,
                    }
                    for e in p.exchanges
                ],
            }
        return out


@dataclass(frozen=True)
class LoopResult:
    scenario: str
    success: bool
    rounds: tuple[Round, ...]
    message: str = ""

    @property
    def llm_calls(self) -> int:
        return sum(len(r.proposal.exchanges) for r in self.rounds if r.proposal)

    def to_json(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "success": self.success,
            "message": self.message,
            "rounds": [r.to_json() for r in self.rounds],
        }

    def save(self, path: str | Path) -> Path:
        return atomic_write(path, json.dumps(self.to_json(), indent=2))


LLMFactory = Callable[[HouseholdWorld, Callable[[], AnomalyReport | None]], LLM]


def oracle_factory(world: HouseholdWorld, report: Callable[[], AnomalyReport | None]) -> LLM:
    """The **oracle** (upper bound only): answers from the world's true state."""
    return Oracle(world, report)


@dataclass
class _Loop:
    scenario: Scenario
    house: Household
    world: HouseholdWorld
    config: LoopConfig
    llm: LLM
    rounds: list[Round] = field(default_factory=list)
    report: AnomalyReport | None = None
    tried: list[frozenset[str]] = field(default_factory=list)
    searched: dict[str, set[str]] = field(default_factory=dict)
    plans: dict[tuple[str, int], tuple[PlanResult, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        seed = self.scenario.seed if self.config.run.seed is None else self.config.run.seed
        self.seed = seed
        self.belief = belief_from(self.house, self.scenario)
        self.ctx = Context(self.world, self.world, self.belief, np.random.default_rng([seed, 2]))
        self.vocab = vocabulary(self.house)

    def plan(self, goal: Formula | str) -> tuple[PlanResult, Any]:
        """Plan from the current belief (memoised per round: a goal tried for feasibility is
        not planned again when it is then executed)."""
        key = (str(goal), len(self.rounds))
        if key not in self.plans:
            problem = make_problem(
                self.house,
                self.belief,
                goal,
                np.random.default_rng([self.seed, len(self.rounds), 1]),
            )
            self.plans[key] = (solve(problem, self.config.run.planner), problem)
        return self.plans[key]

    def attempt(self, goal: Formula | str, text: str) -> Round:
        result, problem = self.plan(goal)
        if result.plan is None:
            return Round(text, result, None)
        specs = build_specs(self.house, problem, result.plan, self.config.run.exploration)
        self.ctx.recorder = Recorder()  # each round's episode has its own timeline
        episode = execute(specs, self.ctx, self.config.run.executor)
        return Round(text, result, episode)

    def task_holds(self) -> bool:
        """Whether the robot believes the task done."""
        sem = Semantics(load_domain(), {}, {}, strict_costs=False)
        return sem.holds(parse_formula(self.scenario.goal, sem.domain), self.belief.facts)

    def check(self, parse: GoalParse) -> GoalParse:
        """Already-true goals and repeats of exhausted searches are rejected with feedback."""
        errors = []
        for g in parse.goals:
            if isinstance(g, Atom) and g.predicate == "scanned":
                for obj, regions in self.searched.items():
                    if g.args[0] in regions:
                        errors.append(
                            f"{g}: {g.args[0]} was already searched for {obj} from "
                            "several positions without finding it; look elsewhere"
                        )
        key = frozenset(map(str, parse.goals))
        if key in self.tried:
            errors.append(f"{' '.join(sorted(key))} was already tried and did not help")
        if errors:
            return rejected(parse, GoalStatus.REPEATED, errors)
        return self.reachable(parse)

    def reachable(self, parse: GoalParse) -> GoalParse:
        """Goals no plan reaches from the believed state are dropped (when others are
        reachable) or rejected with feedback (when none is)."""
        goals = parse.goals
        if self.plan(And(goals))[0].solved:
            return parse
        ok = [g for g in goals if self.plan(And((g,)))[0].solved]
        bad = [g for g in goals if g not in ok]
        if not ok:
            return rejected(
                parse,
                GoalStatus.UNREACHABLE,
                [
                    f"{g}: no sequence of the robot's actions can achieve it from the current state"
                    for g in bad
                ],
            )
        if len(ok) > 1 and not self.plan(And(tuple(ok)))[0].solved:
            return rejected(
                parse,
                GoalStatus.UNREACHABLE,
                [f"{' '.join(map(str, goals))}: cannot be achieved together"],
            )
        notes = (*parse.notes, *(f"dropped {g}: unreachable" for g in bad))
        return GoalParse(GoalStatus.OK, tuple(ok), (), parse.source, notes)

    def remember(self, report: AnomalyReport) -> None:
        if report.constraint_name == "Detected":
            obj = report.constraint.args[0] if isinstance(report.constraint, Atom) else ""
            views = {v.strip("'") for v in report.explored.get("view", ())}
            self.searched.setdefault(str(obj), set()).update(views)

    def history(self) -> str:
        lines = [
            f"- {obj} was not found on {', '.join(sorted(r))}" for obj, r in self.searched.items()
        ]
        lines += [f"- goals {' '.join(sorted(t))} did not help" for t in self.tried]
        return "\n".join(lines)


def run_loop(
    scenario: Scenario | str | Path,
    llm: LLM | LLMFactory,
    config: LoopConfig | None = None,
) -> LoopResult:
    """Run a household scenario with LLM recovery. ``llm`` is a backend, or a factory that gets
    the world and the current anomaly (how the oracle is built)."""
    config = config or LoopConfig()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario_path(str(scenario)))
    house = household_for(scenario)
    seed = scenario.seed if config.run.seed is None else config.run.seed
    world = HouseholdWorld(house.layout, scenario, np.random.default_rng([seed, 0]))
    holder: dict[str, AnomalyReport | None] = {"report": None}
    backend: LLM = llm if isinstance(llm, LLM) else llm(world, lambda: holder["report"])
    loop = _Loop(scenario, house, world, config, backend)
    goal_text = scenario.goal
    goal: Formula | str = scenario.goal
    for _ in range(config.max_rounds + 1):
        rnd = loop.attempt(goal, goal_text)
        loop.rounds.append(rnd)
        ep = rnd.episode
        if ep is None:
            return _end(loop, False, f"no plan for {goal_text}: {rnd.plan.message}")
        if ep.succeeded:
            if goal_text == scenario.goal or loop.task_holds():
                return _end(loop, loop.task_holds(), "the task is done")
            goal, goal_text = scenario.goal, scenario.goal  # recovered: back to the task
            continue
        if ep.anomaly is None or len([r for r in loop.rounds if r.proposal]) >= config.max_rounds:
            return _end(loop, False, ep.message or "out of LLM rounds")
        holder["report"] = ep.anomaly
        loop.remember(ep.anomaly)
        sit = situation(house, loop.belief, ep.anomaly, scenario.goal, loop.history())
        proposal = propose(sit, backend, loop.vocab, config.method, loop.check)
        loop.rounds[-1] = Round(rnd.goal, rnd.plan, ep, proposal)
        if not proposal.ok:
            return _end(
                loop, False, "the LLM gave no usable goals: " + "; ".join(proposal.parse.errors)
            )
        loop.tried.append(frozenset(map(str, proposal.goals)))
        goal, goal_text = _next_goal(loop, proposal, scenario)
    return _end(loop, False, f"not done after {config.max_rounds} LLM rounds")


def _next_goal(loop: _Loop, proposal: Proposal, scenario: Scenario) -> tuple[Formula, str]:
    """The new goals with the task goals they do not contradict, when that can be planned;
    else the new goals alone (the task is planned again once they are achieved)."""
    new = list(proposal.goals)
    task = parse_formula(scenario.goal, load_domain())
    negated = {g.arg for g in new if isinstance(g, Not)}
    keep = [a for a in atoms_of(task) if a not in negated]
    both = And((*new, *keep))
    if loop.plan(both)[0].solved:
        return both, str(both)
    alone = And(tuple(new))
    return alone, str(alone)


def _end(loop: _Loop, success: bool, message: str) -> LoopResult:
    return LoopResult(loop.scenario.name, success, tuple(loop.rounds), message)


__all__ = [
    "LoopConfig",
    "LoopResult",
    "Round",
    "loop_markdown",
    "oracle_factory",
    "run_loop",
    "save_loop",
]


def loop_markdown(result: LoopResult) -> str:
    """The closed loop as a readable report: each round's goal and outcome, and for each
    anomaly the prompts sent, the answers, the goals taken and the repairs."""
    verdict = "task done" if result.success else "not done"
    lines = [f"# Closed loop: {result.scenario}", "", f"**{verdict}**: {result.message}", ""]
    for i, rnd in enumerate(result.rounds):
        ep = rnd.episode
        status = ep.status.value if ep else f"no plan ({rnd.plan.status.value})"
        lines += [f"## Round {i}: `{rnd.goal}` -> {status}", ""]
        if rnd.plan.plan is not None:
            lines += [
                f"Plan ({len(rnd.plan.plan.steps)} actions, {rnd.plan.stats.total_time:.2f} s):",
                "",
            ]
            lines += [f"{k}. `{s}`" for k, s in enumerate(rnd.plan.plan.steps, 1)] + [""]
        if ep is not None and ep.anomaly is not None:
            lines += ["Anomaly:", "", f"> {ep.anomaly.describe()}", ""]
        if rnd.proposal is not None:
            lines += _proposal_lines(rnd.proposal)
    return "\n".join(lines) + "\n"


def _proposal_lines(p: Proposal) -> list[str]:
    goals = " ".join(map(str, p.goals)) or f"none ({p.parse.status.value})"
    lines = [
        f"### Reasoning ({p.method}): {goals}",
        "",
        f"{p.repairs} repairs, {p.tokens} tokens, {p.latency:.1f} s",
        "",
    ]
    notes = [f"- {e}" for e in (*p.parse.errors, *p.parse.notes)]
    lines += [*notes, ""] if notes else []
    for e in p.exchanges:
        lines += [
            f"#### {e.tag}: prompt",
            "",
            "```text",
            e.request.messages[-1].content.strip(),
            "```",
            "",
            f"#### {e.tag}: answer ({e.response.model})",
            "",
            "```text",
            e.response.text.strip(),
            "```",
            "",
        ]
    return lines


def save_loop(result: LoopResult, folder: str | Path) -> list[Path]:
    """``loop.json``, ``loop.md`` and, per round, the episode report and subtree XML."""
    from llmpas.execution.report import save_episode

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = [result.save(out / "loop.json"), atomic_write(out / "loop.md", loop_markdown(result))]
    for i, rnd in enumerate(result.rounds):
        if rnd.episode is not None:
            files += save_episode(rnd.episode, out / f"round{i}", title=f"Round {i}: {rnd.goal}")
    return files
