"""The closed loop of LLM-PAS, once for every world: plan -> execute -> on an anomaly, reason ->
validate -> replan from the believed state with the new goals (and the task goals when they can
be planned together) -> resume, for a bounded number of rounds.

A world supplies parts (:class:`llmpas.worlds.api.Session`): the problem for a goal from its
belief, the decomposition of a plan into conditional subtrees, the robot and its perception, the
prompt tables and a search model. This module is the only place that plans, executes and asks the
LLM in a run (:func:`plan`, :func:`execute`, :func:`close_loop`, :func:`run`); it imports no world.

The belief carries over between rounds (what the robot saw while recovering is what lets it
finish the task); the world's truth is read only by :meth:`Session.achieved` (a judge, after
the loop) and by a labelled oracle.
"""

from __future__ import annotations

import html
import json
import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import Any

from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Recorder
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode
from llmpas.execution.executor import execute as execute_specs
from llmpas.files import atomic_write
from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.problem import Problem, parse_formula
from llmpas.language.semantics import Semantics
from llmpas.planning import PlannerConfig, PlanResult, PlanStatus, solve
from llmpas.reasoning.assists import Assists
from llmpas.reasoning.goals import GoalParse, GoalStatus, Literal
from llmpas.reasoning.llm import LLM, LLMError, Request, Response
from llmpas.reasoning.methods import MethodConfig, Proposal, propose, rejected
from llmpas.reasoning.prompts import situation
from llmpas.recovery import Stages, conjuncts, kept_goal, out_of_order
from llmpas.safetext import fenced, printable
from llmpas.worlds.api import RunOptions, Session, World


@dataclass(frozen=True)
class LoopSettings:
    """How the loop reasons, in every world (:class:`~llmpas.worlds.api.RunOptions`: how the
    world runs)."""

    method: MethodConfig = field(default_factory=MethodConfig)
    max_rounds: int = 3  # LLM consultations at most
    deadline: float | None = None  # seconds for the whole loop (checked between its steps)
    assists: Assists = field(default_factory=Assists)  # what the loop does for the LLM
    # the task's intent (a task file's ``[judge] success``, PDDL): what ends the loop, so that
    # an equivalent object can satisfy it; None: the task goal itself
    success: str | None = None

    def __post_init__(self) -> None:
        if self.success is not None and not self.success.strip():
            raise ValueError("success must be a PDDL formula, got an empty text")
        if self.max_rounds < 0:
            raise ValueError(f"max_rounds must be >= 0, got {self.max_rounds}")
        if self.deadline is not None and not (math.isfinite(self.deadline) and self.deadline > 0):
            raise ValueError(f"deadline must be a positive number of seconds, got {self.deadline}")


@dataclass(frozen=True)
class Round:
    """One plan-and-execute round, and the LLM's answer to its anomaly (if any)."""

    goal: str
    plan: PlanResult
    episode: Episode | None
    proposal: Proposal | None = None
    specs: tuple[SubtreeSpec, ...] = field(default=(), compare=False, repr=False)

    def to_json(self) -> dict[str, Any]:
        ep = self.episode
        out: dict[str, Any] = {
            "goal": self.goal,
            "plan": self.plan.to_json(),
            "status": ep.status.value if ep else "no-plan",
            "anomaly": ep.anomaly.to_json() if ep and ep.anomaly else None,
            "episode": ep.to_json() if ep else None,
        }
        if self.proposal is not None:
            p = self.proposal
            out["reasoning"] = {
                "method": p.method,
                "status": p.parse.status.value,
                "goals": [str(g) for g in p.goals],
                "errors": list(p.parse.errors),
                "notes": list(p.parse.notes),
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


class LoopStatus(Enum):
    """How a loop ended (``running``: a record written while it runs)."""

    DONE = "done"
    NOT_DONE = "not-done"
    DEADLINE = "deadline"
    LLM_ERROR = "llm-error"
    CRASHED = "crashed"
    INTERRUPTED = "interrupted"
    RUNNING = "running"


@dataclass(frozen=True)
class LoopResult:
    scenario: str
    success: bool  # judged in the world's truth where it has a judge, else the robot's belief
    rounds: tuple[Round, ...]
    message: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)  # seconds, where a world counts
    llm_time: float = 0.0  # seconds spent proposing goals (the LLM and the checks of its answers)
    status: LoopStatus | None = None  # None: done or not-done, from ``success``
    error: str = ""  # what stopped the loop when it did not end by itself

    def __post_init__(self) -> None:
        if self.status is None:
            done = LoopStatus.DONE if self.success else LoopStatus.NOT_DONE
            object.__setattr__(self, "status", done)

    @property
    def llm_calls(self) -> int:
        return sum(len(r.proposal.exchanges) for r in self.rounds if r.proposal)

    def to_json(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario,
            "success": self.success,
            "message": self.message,
            "status": self.status.value if self.status else None,
            "error": self.error or None,
            "llm_calls": self.llm_calls,
            "llm_time": round(self.llm_time, 3),
            "timings": {k: round(v, 3) for k, v in self.timings.items()},
            "rounds": [r.to_json() for r in self.rounds],
        }

    def save(self, path: str | Path) -> Path:
        return atomic_write(path, json.dumps(self.to_json(), indent=2))


UNJUDGED = (PlanStatus.TIMEOUT, PlanStatus.CRASHED, PlanStatus.ERROR)  # no verdict
OnRound = Callable[["LoopResult"], object]  # gets the record so far after every step
LLMFor = Callable[[Any], LLM]  # a backend built on the world's session (a labelled oracle)


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
    session: Session, result: PlanResult, problem: Problem
) -> tuple[tuple[SubtreeSpec, ...], Episode | None]:
    """Execute a plan found by :func:`plan` as the world's conditional subtrees (None: there is
    no plan). Each episode gets its own timeline."""
    if result.plan is None:
        return (), None
    specs = tuple(session.decompose(problem, result.plan))
    session.context.recorder = Recorder()
    return specs, execute_specs(specs, session.context, session.executor)


@dataclass
class _Loop:
    session: Session
    method: MethodConfig
    max_rounds: int
    rounds: list[Round] = field(default_factory=list)
    report: AnomalyReport | None = None
    tried: list[frozenset[str]] = field(default_factory=list)  # achieved, did not help
    pending: frozenset[str] | None = None  # the goals being pursued
    searched: dict[str, set[str]] = field(default_factory=dict)
    seen: dict[tuple[str, str], frozenset[Atom]] = field(default_factory=dict)  # at the search
    plans: dict[tuple[str, int], tuple[PlanResult, Any]] = field(default_factory=dict)
    llm_time: float = 0.0
    deadline: float | None = None
    on_round: OnRound | None = None
    clock: Callable[[], float] = time.monotonic
    timings: dict[str, float] = field(default_factory=dict)
    assists: Assists = field(default_factory=Assists)
    success: str | None = None  # the task's intent (None: the task goal)
    stages: Stages = field(default_factory=Stages)  # recovery goals reached and still to reach

    def __post_init__(self) -> None:
        if not self.assists.repair:
            self.method = replace(self.method, repairs=0)
        self.sem = Semantics(self.session.domain, {}, {}, strict_costs=False)
        self.search = self.session.search
        self.start = self.clock()

    def run(self, backend: LLM) -> LoopResult:
        goal, text = self.task_goal()
        on_task = True  # the round plans the task (with the recovery goals kept), not goals
        steps = 2 * self.max_rounds + 1  # the task, then per LLM round: goals + task
        while steps > 0:
            steps -= 1
            if self.expired():
                return self.stop_at_deadline()
            rnd = self.attempt(goal, text)
            self.rounds.append(rnd)
            self.record()
            ep = rnd.episode
            asked = len([r for r in self.rounds if r.proposal])
            if ep is not None and ep.succeeded:
                if on_task or self.task_holds():
                    return self.end(self.task_holds(), "the task is done")
                self.stages.reached(self.recovery_goals(rnd))
                self.searched_in(rnd)
                if self.stages.queue:  # the LLM's next goals, in the order it wrote them
                    goal, text = self.next_goal(self.stages.queue)
                    steps += 1
                    continue
                if self.pending is not None:  # achieved; if the task fails again, it did not help
                    self.tried.append(self.pending)
                goal, text = self.task_goal()  # recovered: back to the task
                on_task = True
                continue
            if ep is None:
                # after a recovery that did not settle the anomaly (a search that found
                # nothing), the task cannot be planned yet: the same anomaly goes back to the LLM
                report = self.report
                if report is None and on_task:
                    report = self.report = self.unknown_place()  # the task names a lost object
                    if report is not None:
                        self.remember(report)
                if report is None or not on_task or asked >= self.max_rounds:
                    return self.end(False, f"no plan for {text}: {rnd.plan.message}")
            else:
                if ep.anomaly is not None and self.task_holds():
                    return self.end(True, f"the task holds: {ep.anomaly.describe()}")
                if ep.anomaly is None or asked >= self.max_rounds:
                    return self.end(False, ep.message or "out of LLM rounds")
                report = self.report = ep.anomaly
                self.remember(report)
            if self.expired():
                return self.stop_at_deadline()
            sit = self.situation(report)
            t = time.perf_counter()
            a = self.assists
            proposal = propose(
                sit,
                backend,
                self.session.vocabulary,
                self.method,
                self.check if a.validation or a.search_rewrite else None,
                self.exhausted() if a.grammar_pruning else (),
                prune=a.grammar_pruning,
            )
            self.llm_time += time.perf_counter() - t
            self.rounds[-1] = replace(rnd, proposal=proposal)
            self.record()
            if not proposal.ok:
                errors = "; ".join(proposal.parse.errors)
                return self.end(False, "the LLM gave no usable goals: " + errors)
            # goals whose execution fails are not blamed: only achieved ones count as tried
            self.pending = frozenset(map(str, proposal.goals))
            goal, text = self.next_goal(list(proposal.goals))
            on_task = False
        return self.end(False, f"not done after {self.max_rounds} LLM rounds")

    def end(
        self,
        success: bool,
        message: str,
        status: LoopStatus | None = None,
        error: str = "",
    ) -> LoopResult:
        rounds = tuple(self.rounds)
        return LoopResult(
            self.session.name,
            success,
            rounds,
            message,
            timings={**self.session.timings, **self.timings},
            llm_time=self.llm_time,
            status=status,
            error=error,
        )

    def record(self, result: LoopResult | None = None) -> None:
        """Hand the record so far (or the final one) to ``on_round`` (which saves it)."""
        if self.on_round is not None:
            running = f"running: {len(self.rounds)} rounds so far"
            self.on_round(result or self.end(False, running, LoopStatus.RUNNING))

    def expired(self) -> bool:
        return self.deadline is not None and self.clock() - self.start >= self.deadline

    def remaining(self) -> float:
        return math.inf if self.deadline is None else self.deadline - (self.clock() - self.start)

    def stop_at_deadline(self) -> LoopResult:
        spent = self.clock() - self.start
        message = f"deadline: stopped after {spent:.1f} s (deadline {self.deadline:g} s)"
        return self.end(False, message, LoopStatus.DEADLINE, message)

    def plan(self, goal: Formula | str) -> tuple[PlanResult, Any]:
        """Plan from the current belief (memoised per round: a goal tried for feasibility is
        not planned again when it is then executed)."""
        key = (str(goal), len(self.rounds))
        if key not in self.plans:
            t = time.perf_counter()
            self.plans[key] = plan(self.session, goal, len(self.rounds))
            self.count("plan", time.perf_counter() - t)
        return self.plans[key]

    def count(self, what: str, seconds: float) -> None:
        self.timings[what] = self.timings.get(what, 0.0) + seconds

    def look(self, place: str) -> Atom:
        """The goal that searches ``place``."""
        return Atom(self.search.predicate, (place,))

    def situation(self, report: AnomalyReport) -> Any:
        """The prompt's text for an anomaly, with what was tried before."""
        s = self.session
        return situation(
            s.prompts,
            report.describe(),
            s.environment(),
            s.task,
            self.history(),
            report.constraint,
        )

    def attempt(self, goal: Formula | str, text: str) -> Round:
        result, problem = self.plan(goal)
        t = time.perf_counter()
        specs, episode = execute(self.session, result, problem)
        if episode is not None:
            self.count("execute", time.perf_counter() - t)
        return Round(text, result, episode, specs=specs)

    def task_holds(self) -> bool:
        """Whether the robot believes the task done: its intent (``success``) where the run
        has one, else its goal; read in the facts the planner plans from."""
        intent = parse_formula(self.success or self.session.task, self.sem.domain)
        return self.sem.holds(intent, self.facts(intent))

    def facts(self, goal: Formula) -> frozenset[Atom]:
        """The facts the planner would plan ``goal`` from now: the belief and what problem
        construction adds (blocking and capacity facts, say). Every check of a goal reads these,
        so that a check and the planner never disagree."""
        return self.session.problem(goal, len(self.rounds)).init

    def task_goal(self) -> tuple[Formula, str]:
        """The task with the recovery goals reached so far kept true (:mod:`llmpas.recovery`),
        when that can be planned; else the task alone."""
        task = parse_formula(self.session.task, self.sem.domain)
        if self.stages.kept:
            both = kept_goal(task, self.stages.kept)
            if self.plan(both)[0].solved:
                return both, str(both)
        return task, self.session.task

    def recovery_goals(self, rnd: Round) -> list[Literal]:
        """The LLM's goals a recovery round reached, to keep true: neither its task conjuncts
        nor its searches (a look stays done: nothing in the world undoes it)."""
        goal = parse_formula(rnd.goal, self.sem.domain)
        task = set(atoms_of(parse_formula(self.session.task, self.sem.domain)))
        pending = {str(g) for g in self.stages.queue} | set(self.pending or ())
        return [
            g
            for g in conjuncts(goal)
            if isinstance(g, Atom | Not)
            and str(g) in pending | {str(k) for k in self.stages.kept}
            and (g.arg if isinstance(g, Not) else g) not in task
            and not (isinstance(g, Atom) and g.predicate == self.search.predicate)
        ]

    def next_goal(self, goals: list[Literal]) -> tuple[Formula, str]:
        """The new goals with the task goals they do not contradict and the recovery goals
        reached before, when that can be planned, the plan does not repeat a step that failed
        for a reason the belief does not hold, and it reaches the goals in the order written;
        else the first goal (the others follow, one at a time) when the order was not kept;
        else the new goals alone, with those reached before when that can be planned (the task
        is planned again once they are achieved)."""
        self.stages.queue = []
        task = parse_formula(self.session.task, self.sem.domain)
        both = kept_goal(task, self.stages.kept, goals)
        result, problem = self.plan(both)
        repeats = result.solved and self.repeats_unexplained(result)
        if result.solved and not repeats and not self.reordered(result, problem, goals):
            return both, str(both)
        goal = kept_goal(And(()), self.stages.kept, goals)
        result, problem = self.plan(goal)
        if not result.solved:
            goal = And(tuple(goals))
            result, problem = self.plan(goal)
        if result.solved and self.reordered(result, problem, goals):
            self.stages.queue = list(goals[1:])
            goal = kept_goal(And(()), self.stages.kept, goals[:1])
            if not self.plan(goal)[0].solved:
                goal = And(tuple(goals[:1]))
        return goal, str(goal)

    def reordered(self, result: PlanResult, problem: Problem, goals: list[Literal]) -> bool:
        """The plan reaches the goals out of the order written. Searches are left out: a look
        changes nothing in the world, so the order of looks is the planner's to choose."""
        changes = [
            g for g in goals if not (isinstance(g, Atom) and g.predicate == self.search.predicate)
        ]
        return result.plan is not None and out_of_order(self.sem, problem, result.plan, changes)

    def unknown_place(self) -> AnomalyReport | None:
        """The task cannot be planned and names an object the robot knows of but cannot place:
        an anomaly (a failed detection of it, with nothing looked at yet), so that the LLM is
        asked where to search instead of the loop ending with no plan."""
        task = parse_formula(self.session.task, self.sem.domain)
        lost = sorted({o for a in atoms_of(task) for o in a.args if self.search.lost(o)})
        if not lost:
            return None
        obj = lost[0]
        where = Atom(self.search.location, (obj, "?"))
        belief = tuple(sorted(self.session.context.belief.facts))
        return AnomalyReport(
            action="plan",
            args=(obj,),
            steps=(),
            subtree="plan",
            sub_action="locate",
            constraint=where,
            constraint_name=self.search.detection,
            reason=f"where {obj} is, is unknown: the task cannot be planned before it is found",
            explored={},
            attempts=0,
            failures={},
            observations=(),
            belief=belief,
        )

    def repeats_unexplained(self, result: PlanResult) -> bool:
        """The plan contains the step whose failure is the anomaly, and the anomaly is that
        step's own failure (its literal names the action, with no arguments: no fact of the
        belief says why). Nothing tells the planner to achieve the new goals before it, so
        planned together with the task it would fail again."""
        report = self.report
        c = report.constraint if report is not None else None
        if report is None or not (isinstance(c, Atom) and not c.args):
            return False
        if c.predicate != report.action or result.plan is None:
            return False
        return any(
            step.action == report.action and step.args == report.args for step in result.plan.steps
        )

    def check(self, parse: GoalParse) -> GoalParse:
        """Already-true goals are dropped; repeats of exhausted searches and of attempts that
        did not help, and unreachable goals, are rejected with feedback."""
        raw = parse.goals
        rewrite = self.assists.search_rewrite
        if rewrite:
            parse = self.as_searches(parse)
        if not self.assists.validation:
            return parse
        errors = []
        bad = []
        searching = self.searching()
        for g in parse.goals:
            if isinstance(g, Atom) and g.predicate == self.search.predicate:
                for obj, regions in searching.items():
                    if g.args[0] in regions:
                        bad.append(g)
                        errors.append(
                            f"{g}: {g.args[0]} was already searched for {obj} from "
                            "several positions without finding it; look elsewhere"
                            + self.not_searched(obj, regions)
                        )
        if errors:
            culprits = [r for r in raw if (self.as_goal(r) if rewrite else r) in bad]
            return rejected(parse, GoalStatus.REPEATED, errors, culprits)
        parse = self.drop_true(parse)
        if not parse.ok:
            return replace(parse, rejected=raw)
        parse = self.reachable(parse)
        if not parse.ok:
            culprits = [r for r in raw if (self.as_goal(r) if rewrite else r) in parse.rejected]
            return replace(parse, rejected=tuple(culprits))
        key = frozenset(map(str, parse.goals))
        if key in self.tried:
            errors = [f"{' '.join(sorted(key))} was already tried and did not help"]
            return rejected(parse, GoalStatus.REPEATED, errors, raw if len(raw) == 1 else ())
        return parse

    def exhausted(self) -> tuple[Literal, ...]:
        """Searches that cannot help (places already searched for a lost object), in both
        spellings: ``(scanned P)`` and ``(on X P)``; left out of the LLM's decoding."""
        out: list[Literal] = []
        for obj, regions in self.searching().items():
            if self.search.lost(obj):
                for place in sorted(regions):
                    # (on X P) stays out even when it is the task's literal: X is lost, so no
                    # plan reaches it before X is found (it is not read as a search, though)
                    out += [self.look(place), Atom(self.search.location, (obj, place))]
        return tuple(out)

    def searching(self) -> dict[str, set[str]]:
        """The places searched for each object: those searched in vain this run (while what the
        robot believes about them is unchanged) and, for an object still lost, every place the
        belief says was searched (``(scanned P)``: by the scenario, an earlier round or an
        earlier run; such a goal would already hold). The prompt, the decoding grammar and the
        validator all read this."""
        self.refresh()
        out = {obj: set(places) for obj, places in self.searched.items()}
        scanned = {
            a.args[0]
            for a in self.session.context.belief.facts
            if a.predicate == self.search.predicate and a.args
        }
        if scanned:
            task = parse_formula(self.session.task, self.sem.domain)
            named = {o for a in atoms_of(task) for o in a.args}
            for obj in sorted(named | set(out)):
                if self.search.lost(obj):
                    out.setdefault(obj, set()).update(scanned)
        return out

    def as_searches(self, parse: GoalParse) -> GoalParse:
        """``(on X P)`` for a lost object X and a place P the robot can search is read as the
        hypothesis it states: look at P, ``(scanned P)`` (no plan can put X anywhere before it
        is found). Only a recovery goal is read so: the task's own literal stays what it is."""
        goals: list[Literal] = []
        notes = list(parse.notes)
        for g in parse.goals:
            search = self.as_goal(g)
            if search != g and isinstance(g, Atom):
                notes.append(f"read {g} as {search}: where {g.args[0]} is, is unknown")
            if search not in goals:
                goals.append(search)
        if goals == list(parse.goals):
            return parse
        return GoalParse(parse.status, tuple(goals), parse.errors, parse.source, tuple(notes))

    def as_goal(self, g: Literal) -> Literal:
        """How the loop reads an answer's literal: :meth:`as_search`, except the task's own."""
        task = set(atoms_of(parse_formula(self.session.task, self.sem.domain)))
        return g if g in task else self.as_search(g)

    def as_search(self, g: Literal) -> Literal:
        """``(scanned P)`` for ``(on X P)`` with X lost and P a place to search; else ``g``."""
        if not (isinstance(g, Atom) and g.predicate == self.search.location and len(g.args) == 2):
            return g
        if self.search.lost(g.args[0]) and g.args[1] in self.search.places():
            return self.look(g.args[1])
        return g

    def drop_true(self, parse: GoalParse) -> GoalParse:
        """Goals the robot believes already hold are dropped (all of them: rejected); read in
        the facts the planner plans from (:meth:`facts`)."""
        facts = self.facts(And(parse.goals))
        true = [g for g in parse.goals if self.sem.holds(g, facts)]
        if not true:
            return parse
        if len(true) == len(parse.goals):
            shown = ", ".join(map(str, true))
            msg = f"every goal already holds: {shown}; propose goals that are not yet true"
            return rejected(parse, GoalStatus.ALREADY_TRUE, [msg])
        kept = tuple(g for g in parse.goals if g not in true)
        notes = (*parse.notes, *(f"dropped {g}: it already holds" for g in true))
        return GoalParse(GoalStatus.OK, kept, (), parse.source, notes)

    def reachable(self, parse: GoalParse) -> GoalParse:
        """Goals no plan reaches from the believed state are dropped (when others are
        reachable) or rejected with feedback (when none is)."""
        goals = parse.goals
        if self.plan(And(goals))[0].solved:
            return parse
        ok = [g for g in goals if self.plan(And((g,)))[0].solved]
        bad = [g for g in goals if g not in ok]
        unjudged = [g for g in bad if self.plan(And((g,)))[0].status in UNJUDGED]
        if unjudged:  # a safety net fired: no verdict, and not "unreachable"
            why = [f"{g}: not judged: {self.plan(And((g,)))[0].message}" for g in unjudged]
            return rejected(parse, GoalStatus.UNREACHABLE, why, unjudged)
        if not ok:
            return rejected(
                parse,
                GoalStatus.UNREACHABLE,
                [self.why_unreachable(g) for g in bad],
                bad,
            )
        if len(ok) > 1 and not self.plan(And(tuple(ok)))[0].solved:
            return rejected(
                parse,
                GoalStatus.UNREACHABLE,
                [f"{' '.join(map(str, goals))}: cannot be achieved together"],
            )
        notes = (*parse.notes, *(f"dropped {g}: unreachable" for g in bad))
        return GoalParse(GoalStatus.OK, tuple(ok), (), parse.source, notes)

    def why_unreachable(self, goal: Literal) -> str:
        """The feedback for a goal no plan reaches, naming objects the robot has lost."""
        text = f"{goal}: no sequence of the robot's actions can achieve it from the current state"
        atom = goal.arg if isinstance(goal, Not) else goal
        lost = [a for a in getattr(atom, "args", ()) if self.search.lost(a)]
        if lost:
            text += (
                f" ({', '.join(lost)}: location unknown; find it first with a goal "
                f"({self.search.predicate} PLACE) for a place not searched yet)"
            )
        return text

    def remember(self, report: AnomalyReport) -> None:
        """A failed detection: the places it looked at are searched for its object."""
        if report.constraint_name == self.search.detection:
            obj = report.constraint.args[0] if isinstance(report.constraint, Atom) else ""
            for place in self.search.looked_at(report):
                self.searched_for(str(obj), place)

    def searched_in(self, rnd: Round) -> None:
        """A search goal reached while an object is still lost: that place is searched."""
        lost = [o for o in self.searched if self.search.lost(o)]
        for goal in atoms_of(parse_formula(rnd.goal, self.sem.domain)):
            if goal.predicate == self.search.predicate:
                for obj in lost:
                    self.searched_for(obj, goal.args[0])

    def searched_for(self, obj: str, place: str) -> None:
        self.searched.setdefault(obj, set()).add(place)
        self.seen[obj, place] = self.about(place)

    def about(self, place: str, state: Any = None) -> frozenset[Atom]:
        """What the robot believes about ``place``: the facts that name it, and where objects
        are believed to rest there (``(location OBJ place)``, derived; ``state``: the belief's,
        when the caller has it)."""
        facts = self.session.context.belief.facts
        named = {a for a in facts if place in a.args}
        objects = self.session.vocabulary.predicates.get(self.search.location, ((),))[0]
        state = self.sem.state(facts) if state is None else state
        there = {Atom(self.search.location, (o, place)) for o in sorted(objects)}
        return frozenset(named | {a for a in there if self.sem.holds(a, state)})

    def refresh(self) -> None:
        """A place searched in vain stays searched while what the robot believes about it is
        unchanged; a cover lifted from it or an object put there makes it worth another look."""
        state = self.sem.state(self.session.context.belief.facts)  # derived once for all places
        for obj, places in self.searched.items():
            for place in sorted(places):
                if self.seen.get((obj, place)) != self.about(place, state):
                    places.discard(place)
                    self.seen.pop((obj, place), None)

    def not_searched(self, obj: str, regions: set[str]) -> str:
        rest = [p for p in self.search.places() if p not in regions]
        listed = rest and self.assists.unsearched_list
        return f" (not searched yet: {', '.join(rest)})" if listed else ""

    def history(self) -> str:
        lines = []
        for obj, regions in self.searching().items():
            if not regions:
                continue
            lines.append(f"- {obj} was not found on {', '.join(sorted(regions))}")
            rest = [p for p in self.search.places() if p not in regions]
            if self.assists.unsearched_list:
                lines.append(f"- places not searched yet for {obj}: {', '.join(rest)}")
        lines += [f"- goals {' '.join(sorted(t))} did not help" for t in self.tried]
        return "\n".join(lines)


def close_loop(
    session: Session,
    llm: LLM | LLMFor,
    settings: LoopSettings,
    on_round: OnRound | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> LoopResult:
    """Run the closed loop on an open ``session``. ``llm`` is a backend, or a function of the
    session that builds one (a labelled oracle, which reads the world's truth).

    ``on_round`` gets the record after every plan-and-execute step and every LLM answer
    (status ``running``), and the final one; when an LLM error, a crash or an interrupt ends
    the loop it gets the rounds run so far with the error recorded, and the exception goes on.
    ``settings.deadline`` (seconds on ``clock``) stops the loop cleanly between steps."""
    loop = _Loop(
        session,
        settings.method,
        settings.max_rounds,
        deadline=settings.deadline,
        on_round=on_round,
        clock=clock,
        assists=settings.assists,
        success=settings.success,
    )
    try:
        backend = llm if isinstance(llm, LLM) else llm(session)
        if settings.deadline is not None:
            backend = _ByDeadline(backend, loop.remaining)
        result = loop.run(backend)
    except _DeadlineReached:
        result = loop.stop_at_deadline()
    except LLMError as err:
        loop.record(loop.end(False, f"LLM error: {err}", LoopStatus.LLM_ERROR, str(err)))
        raise
    except KeyboardInterrupt:
        loop.record(loop.end(False, "interrupted", LoopStatus.INTERRUPTED, "KeyboardInterrupt"))
        raise
    except Exception as err:
        error = f"{type(err).__name__}: {err}"
        loop.record(loop.end(False, f"crashed: {error}", LoopStatus.CRASHED, error))
        raise
    loop.record(result)
    return result


class _DeadlineReached(Exception):
    """The loop's deadline passed while the LLM was answering."""


class _ByDeadline:
    """An LLM whose answers must come before the loop's deadline: each call runs in a daemon
    thread that is abandoned when the time is up (the backend's own timeout still ends it)."""

    def __init__(self, inner: LLM, remaining: Callable[[], float]) -> None:
        self.inner = inner
        self.name = inner.name
        self.remaining = remaining

    def complete(self, request: Request) -> Response:
        left = self.remaining()
        if left <= 0:
            raise _DeadlineReached
        out: list[Response | BaseException] = []

        def call() -> None:
            try:
                out.append(self.inner.complete(request))
            except BaseException as err:  # handed over to the loop's thread
                out.append(err)

        worker = threading.Thread(target=call, name="llm-call", daemon=True)
        worker.start()
        worker.join(left if math.isfinite(left) else None)
        if not out:
            raise _DeadlineReached
        if isinstance(out[0], BaseException):
            raise out[0]
        return out[0]


def run(
    world: World,
    scenario: Any,
    llm: LLM | LLMFor,
    settings: LoopSettings | None = None,
    options: RunOptions | None = None,
    out: str | Path | None = None,
    on_round: OnRound | None = None,
) -> LoopResult:
    """Open ``scenario`` in ``world``, run the closed loop, judge the task in the world's truth
    (where the world has a judge) and, with ``out``, write the run folder (``loop.json`` and
    ``loop.md`` after every step, each round's episode and subtrees, the world's own files)."""
    hooks = [h for h in (on_round, _records_to(out)) if h is not None]
    save = None if out is None else (lambda r, session: save_loop(r, out, session))
    return _opened(world, scenario, llm, settings or LoopSettings(), options, hooks, save)


def run_once(
    world: World,
    scenario: Any,
    options: RunOptions | None = None,
    out: str | Path | None = None,
) -> LoopResult:
    """Plan the task once and execute it, with no LLM (one round), judged like :func:`run`;
    ``out``: an episode folder (the episode's reports and subtrees, the world's own files)."""
    save = None if out is None else (lambda r, session: save_once(r, out, session))
    return _opened(world, scenario, _NoLLM(), LoopSettings(max_rounds=0), options, [], save)


def _opened(
    world: World,
    scenario: Any,
    llm: LLM | LLMFor,
    settings: LoopSettings,
    options: RunOptions | None,
    hooks: list[OnRound],
    save: Callable[[LoopResult, Session], object] | None,
) -> LoopResult:
    """The loop on a session of ``world``, judged in its truth, then saved while it is open."""
    t0 = time.perf_counter()
    with world.open(scenario, options or RunOptions()) as session:
        result = close_loop(session, llm, settings, _each(hooks) if hooks else None)
        result = _judged(result, session, time.perf_counter() - t0)
        if save is not None:
            save(result, session)
    return result


class _NoLLM:
    """The backend of a run without reasoning: never asked (no LLM rounds are allowed)."""

    name = "none"

    def complete(self, request: Request) -> Response:
        raise LLMError("no LLM in this run")


def _records_to(out: str | Path | None) -> OnRound | None:
    return None if out is None else (lambda result: save_records(result, out))


def _each(hooks: list[OnRound]) -> OnRound:
    def call(result: LoopResult) -> None:
        for hook in hooks:
            hook(result)

    return call


def _judged(result: LoopResult, session: Session, seconds: float) -> LoopResult:
    """The loop's result with the world's verdict (when it has a judge) and its timings."""
    timings = {**session.timings, **result.timings, "total": seconds}
    ended = result.status not in (LoopStatus.DONE, LoopStatus.NOT_DONE)
    judged = None if ended else session.achieved()
    if judged is None:
        return replace(result, timings=timings)
    return replace(result, success=judged, timings=timings, status=None)


__all__ = [
    "LLMFor",
    "LoopResult",
    "LoopSettings",
    "LoopStatus",
    "OnRound",
    "Round",
    "close_loop",
    "execute",
    "loop_markdown",
    "plan",
    "run",
    "run_once",
    "save_loop",
    "save_once",
    "save_records",
]


def loop_markdown(result: LoopResult) -> str:
    """The closed loop as a readable report: each round's goal and outcome, and for each
    anomaly the prompts sent, the answers, the goals taken and the repairs."""
    verdict = "task done" if result.success else "not done"
    if result.status not in (LoopStatus.DONE, LoopStatus.NOT_DONE, None):
        verdict += f" ({result.status.value})"
    title = f"# Closed loop: {_md(result.scenario)}"
    lines = [title, "", f"**{verdict}**: {_md(result.message)}", ""]
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
            lines += ["Anomaly:", "", f"> {_md(ep.anomaly.describe())}", ""]
        if rnd.proposal is not None:
            lines += _proposal_lines(rnd.proposal)
    return printable("\n".join(lines) + "\n")


def _md(text: str) -> str:
    """Text from outside (an answer, a file name) on a Markdown line: one printable line, with
    no raw HTML."""
    return html.escape(printable(text, keep_newlines=False), quote=False)


def _proposal_lines(p: Proposal) -> list[str]:
    goals = " ".join(map(str, p.goals)) or f"none ({p.parse.status.value})"
    lines = [
        f"### Reasoning ({p.method}): {goals}",
        "",
        f"{p.repairs} repairs, {p.tokens} tokens, {p.latency:.1f} s",
        "",
    ]
    notes = [f"- {_md(e)}" for e in (*p.parse.errors, *p.parse.notes)]
    lines += [*notes, ""] if notes else []
    for e in p.exchanges:
        lines += [
            f"#### {_md(e.tag)}: prompt",
            "",
            *fenced(e.request.messages[-1].content.strip()),
            "",
            f"#### {_md(e.tag)}: answer ({_md(e.response.model)})",
            "",
            *fenced(e.response.text.strip()),
            "",
        ]
    return lines


def save_loop(result: LoopResult, folder: str | Path, session: Session | None = None) -> list[Path]:
    """The run folder: the world's own files (snapshots, a GIF, its log), per executed round
    ``round-I/`` with the episode report and the subtrees' XML, ``loop.json`` and ``loop.md``."""
    from llmpas.execution.report import save_episode

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = session.save(out) if session is not None else []
    for i, rnd in enumerate(result.rounds):
        if rnd.episode is not None:
            title = f"{result.scenario}, round {i}: {rnd.goal}"
            files += save_episode(rnd.episode, out / f"round-{i}", list(rnd.specs), title)
    return files + save_records(result, out)


def save_once(result: LoopResult, folder: str | Path, session: Session | None = None) -> list[Path]:
    """The folder of a run without reasoning: the world's own files and the one round's
    episode reports and subtrees at the top."""
    from llmpas.execution.report import save_episode

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = session.save(out) if session is not None else []
    rnd = result.rounds[0] if result.rounds else None
    if rnd is not None and rnd.episode is not None:
        files += save_episode(rnd.episode, out, list(rnd.specs), f"{result.scenario}: {rnd.goal}")
    return files


def save_records(result: LoopResult, folder: str | Path) -> list[Path]:
    """``loop.json`` and ``loop.md`` (atomically): written after every step while the loop
    runs, so a crash or an interrupt keeps what happened."""
    out = Path(folder)
    return [result.save(out / "loop.json"), atomic_write(out / "loop.md", loop_markdown(result))]
