"""Judging one closed-loop run of a task: the loop runs with the given LLM and method, and the
verdict is taken on the true final state (see the package's documentation)."""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.experiments.effective import (
    is_effective,
    lost_object,
)
from llmpas.experiments.suite.task_files import Category, SuiteTask
from llmpas.experiments.suite.truth import holds_in_truth
from llmpas.experiments.worlds import LoopConfig
from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Literal
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import Proposal, Situation, answer_reader
from llmpas.reasoning.replan import task_literals
from llmpas.system import LLMFor, LoopResult, run
from llmpas.worlds.household.household_plugin import WORLD, HouseholdSession, household_for
from llmpas.worlds.household.household_reasoning import PROGRAM_CALLS, vocabulary
from llmpas.worlds.household.sim import HouseholdWorld
from llmpas.worlds.kitchen.belief import DETECTION

log = logging.getLogger(__name__)


class Verdict(enum.Enum):
    SUCCESS = "success"  # the loop reported the task done and the truth agrees
    NOT_DONE = "not-done"  # the loop gave up (no usable goals, no plan, out of rounds)
    FALSE_DONE = "false-done"  # the loop believed the task done but the truth disagrees
    NO_ANOMALY = "no-anomaly"  # nothing went wrong: there was nothing to resolve


@dataclass(frozen=True)
class Judgement:
    """The judged outcome of one closed-loop run of one task."""

    task: str
    category: Category | str  # a household task's anomaly type, or another world's name
    verdict: Verdict
    completed: bool  # the loop reported the task done (end-to-end completion)
    resolution_length: int  # plan actions completed after the first anomaly
    anomaly: str  # the first anomaly's violated constraint ("" when none)
    rounds: int
    proposals: int  # LLM consultations (one per anomaly)
    answers: int  # goal answers read (first answers and repairs)
    syntax_errors: int  # goal answers that did not even parse
    repairs: int
    tokens: int
    latency: float  # seconds spent waiting for the LLM
    first_status: str  # the first proposal's parse status ("" when none)
    goals: tuple[str, ...]  # every accepted goal, in order
    message: str
    wall_time: float
    first_goals: str = ""  # the first goal answer's literals, as the method's reader reads them
    first_effective: bool | None = None  # None: no effective sets, or no anomaly
    # what a world's scenario was judged on (experiments.world_tasks): "truth", "perceived" (the
    # world has no truth); "": a suite task, judged on the simulator's true state
    basis: str = ""

    @property
    def success(self) -> bool:
        return self.verdict is Verdict.SUCCESS

    def to_json(self) -> dict[str, Any]:
        return {
            "task": self.task,
            "category": getattr(self.category, "value", self.category),
            "verdict": self.verdict.value,
            "success": self.success,
            "completed": self.completed,
            "resolution_length": self.resolution_length,
            "anomaly": self.anomaly,
            "rounds": self.rounds,
            "proposals": self.proposals,
            "answers": self.answers,
            "syntax_errors": self.syntax_errors,
            "repairs": self.repairs,
            "tokens": self.tokens,
            "latency": round(self.latency, 4),
            "first_status": self.first_status,
            "goals": " ".join(self.goals),
            "message": self.message,
            "wall_time": round(self.wall_time, 3),
            "first_goals": self.first_goals,
            "first_effective": self.first_effective,
            **({"basis": self.basis} if self.basis else {}),
        }


@dataclass(frozen=True)
class Traced:
    """A closed-loop run with the world it ran in (for checks on the true state)."""

    result: LoopResult
    world: HouseholdWorld


def run_traced(task: SuiteTask, llm: LLM | LLMFor, config: LoopConfig) -> Traced:
    """Run the closed loop on ``task`` and keep the simulator (handed over when the backend is
    built; the LLM never sees it unless it is the oracle). The task's ``[judge] success`` (its
    intent, by default its goal) is what ends the loop, as it is what is judged."""
    worlds: list[HouseholdWorld] = []

    def factory(session: HouseholdSession) -> LLM:
        worlds.append(session.sim)
        return llm if isinstance(llm, LLM) else llm(session)

    config = replace(config, success=task.success)
    result = run(WORLD, task.scenario, factory, config, config.options)
    return Traced(result, worlds[0])


def first_anomaly(
    result: LoopResult, task: SuiteTask | None = None
) -> tuple[int, AnomalyReport] | None:
    """The first anomaly of the run and its round: the first episode's anomaly or, for a
    ``task`` whose object's whereabouts are unknown at the start, the loop's question where to
    look (:func:`unknown_start`)."""
    start = unknown_start(result, task) if task is not None else None
    if start is not None:
        return 0, start
    for i, rnd in enumerate(result.rounds):
        if rnd.episode is not None and rnd.episode.anomaly is not None:
            return i, rnd.episode.anomaly
    return None


def unknown_start(result: LoopResult, task: SuiteTask) -> AnomalyReport | None:
    """A task that names an object the robot knows of but believes nowhere cannot be planned
    before the object is found: the loop's first round has no plan and asks where to look (a
    proposal). That question is the run's first anomaly: a failed detection of the object,
    nothing looked at yet (as the loop reports it). None for any other run."""
    first = result.rounds[0] if result.rounds else None
    if first is None or first.plan.plan is not None or first.proposal is None:
        return None
    believed = task.scenario.belief.places()
    literals = task_literals(task.scenario.goal)
    atoms = [lit.arg if isinstance(lit, Not) else lit for lit in literals]
    named = {o for a in atoms if isinstance(a, Atom) for o in a.args}
    lost = sorted(o for o in named if o in believed and believed[o] is None)
    if not lost:
        return None
    return AnomalyReport(
        action="plan",
        args=(lost[0],),
        steps=(),
        subtree="plan",
        sub_action="locate",
        constraint=Atom("on", (lost[0], "?")),
        constraint_name=DETECTION,
        reason=f"where {lost[0]} is, is unknown: the task cannot be planned before it is found",
        explored={},
        attempts=0,
        failures={},
        observations=(),
        belief=(),
    )


def resolution_length(result: LoopResult, task: SuiteTask | None = None) -> int:
    """Plan actions completed after the first anomaly (0 when there was none)."""
    first = first_anomaly(result, task)
    if first is None:
        return 0
    return sum(
        len(r.episode.completed) for r in result.rounds[first[0] + 1 :] if r.episode is not None
    )


def _answer_reader(task: SuiteTask, config: LoopConfig) -> Callable[[str], GoalParse]:
    """How the method reads a goal answer (to count answers that do not even parse): the
    method's own reader (:func:`llmpas.reasoning.methods.answer_reader`)."""
    vocab = vocabulary(household_for(task.scenario))
    blank = Situation("", "", "", "", "", calls=PROGRAM_CALLS)
    read, _ = answer_reader(blank, vocab, config.method)
    return read


def answer_counts(
    proposals: Sequence[Proposal], read: Callable[[str], GoalParse] | None
) -> tuple[int, int]:
    """Goal answers read (first answers and repairs) and those that did not even parse
    (``read`` None: none is read as a syntax error)."""
    answers = syntax = 0
    for p in proposals:
        for ex in p.exchanges:
            if ex.tag != "goals" and not ex.tag.startswith("repair"):
                continue
            answers += 1
            syntax += read is not None and read(ex.response.text).status in (
                GoalStatus.SYNTAX,
                GoalStatus.EMPTY,
            )
    return answers, syntax


def proposal_fields(proposals: Sequence[Proposal]) -> dict[str, Any]:
    """What a judgement keeps of the LLM's proposals: how many, their repairs, tokens, latency,
    the first one's parse status and every goal proposed."""
    return {
        "proposals": len(proposals),
        "repairs": sum(p.repairs for p in proposals),
        "tokens": sum(p.tokens for p in proposals),
        "latency": sum(p.latency for p in proposals),
        "first_status": proposals[0].parse.status.value if proposals else "",
        "goals": tuple(str(g) for p in proposals for g in p.goals),
    }


def judge(
    task: SuiteTask,
    llm: LLM | LLMFor,
    config: LoopConfig,
    keep: Callable[[LoopResult], object] | None = None,
) -> Judgement:
    """Run ``task`` through the closed loop with ``llm`` and judge it on the true final state
    (``keep``: called with the loop's record, e.g. to save it)."""
    start = time.perf_counter()
    traced = run_traced(task, llm, config)
    result = traced.result
    if keep is not None:
        keep(result)
    holds = holds_in_truth(task.success, traced.world.truth)
    first = first_anomaly(result, task)
    if first is None:
        verdict = Verdict.NO_ANOMALY
    elif not result.believed:  # the loop's own verdict (``success`` is the truth's)
        verdict = Verdict.NOT_DONE
    elif not holds:
        verdict = Verdict.FALSE_DONE
    else:
        verdict = Verdict.SUCCESS
    proposals = [r.proposal for r in result.rounds if r.proposal is not None]
    read = _answer_reader(task, config)
    first_goals = first_answer_goals(proposals[0] if proposals else None, read)
    sets = task.effective_sets()
    lost = lost_object(first[1].constraint) if first else None
    first_effective = (  # None: nothing to judge (no sets, or no anomaly to resolve)
        is_effective(first_goals, sets, lost, task.search_places()) if sets and first else None
    )
    answers, syntax = answer_counts(proposals, read)
    return Judgement(
        task=task.name,
        category=task.category,
        verdict=verdict,
        completed=bool(result.believed),
        resolution_length=resolution_length(result, task),
        anomaly=str(first[1].constraint) if first else "",
        rounds=len(result.rounds),
        answers=answers,
        syntax_errors=syntax,
        **proposal_fields(proposals),
        message=result.message,
        wall_time=time.perf_counter() - start,
        first_goals=" ".join(map(str, first_goals)),
        first_effective=first_effective,
    )


def first_answer_goals(
    proposal: Proposal | None, read: Callable[[str], GoalParse]
) -> tuple[Literal, ...]:
    """The literals of a consultation's first goal answer (before any feedback or repair),
    read with the method's reader; () when it did not parse or there was none."""
    if proposal is None:
        return ()
    for ex in proposal.exchanges:
        if ex.tag == "goals":
            parse = read(ex.response.text)
            return parse.goals if parse.ok else ()
    return ()
