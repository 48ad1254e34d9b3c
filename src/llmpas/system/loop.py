"""Round control: plan -> execute -> on an anomaly, ask the LLM (its answers checked by a
:class:`~llmpas.system.checks.GoalChecker`, its searches remembered by a
:class:`~llmpas.system.search.SearchMemory`) -> replan from the believed state with the new
goals (and the task goals when they can be planned together) -> resume, for a bounded number of
rounds (:func:`close_loop`).

The loop takes its LLM in one shape: a factory of the session (:data:`LLMFactory`), called once
when the loop starts; :func:`fixed` makes one of a backend that does not depend on the session.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from llmpas.errors import RobotLostError
from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Recorder
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode
from llmpas.execution.executor import execute as execute_specs
from llmpas.execution.plan_builder import planned_action
from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.problem import Problem, parse_formula
from llmpas.language.semantics import Semantics
from llmpas.planning import Plan, PlannerConfig, PlanResult, solve
from llmpas.reasoning.assists import Assists
from llmpas.reasoning.choose import Ranked, chosen, nothing, rank
from llmpas.reasoning.goals import Literal
from llmpas.reasoning.llm import LLM, Baseline, LLMError, Request, Response
from llmpas.reasoning.methods import MethodConfig, Proposal, method, propose
from llmpas.reasoning.prompts import situation
from llmpas.system.achievable import Makeable, certified
from llmpas.system.candidates import anomaly_objects, enumerate_goals, first_accepted
from llmpas.system.checks import GoalChecker
from llmpas.system.records import LoopResult, LoopStatus, OnRound, Round
from llmpas.system.recovery import Stages, conjuncts, kept_goal, out_of_order
from llmpas.system.search import SearchMemory
from llmpas.worlds.api import Session

LLMFactory = Callable[[Any], LLM]  # Session -> LLM (Any: a world's own session type too)
LLMFor = LLMFactory  # its earlier name


def fixed(llm: LLM) -> LLMFactory:
    """The factory of a backend that does not depend on the session."""

    def factory(session: Session) -> LLM:
        return llm

    return factory


def as_factory(llm: LLM | LLMFactory) -> LLMFactory:
    """``llm`` as the loop takes it: a backend is :func:`fixed`, a factory stays itself."""
    return fixed(llm) if isinstance(llm, LLM) else llm


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
    """The rounds of one run: what was planned and executed, the anomaly being resolved, the
    goals pursued and those tried in vain, and the recovery goals reached."""

    session: Session
    method: MethodConfig
    max_rounds: int
    rounds: list[Round] = field(default_factory=list)
    report: AnomalyReport | None = None
    tried: list[frozenset[str]] = field(default_factory=list)  # achieved, did not help
    failed: list[tuple[frozenset[str], str]] = field(default_factory=list)  # execution failed
    # the goals whose execution failed with nothing done since: proposed again they are
    # rejected; once a round has carried out a step the state has changed and they may be
    # proposed again (the mug taken out of the sink, rinsing the apple there can succeed)
    failed_since: set[frozenset[str]] = field(default_factory=set)
    just_failed: frozenset[str] = frozenset()  # the literals of the goal whose round just failed
    ranked_for: str = ""  # choosing methods: the anomaly the ranking was made for
    ranked: list[Ranked] = field(default_factory=list)  # that ranking
    ranking: list[Ranked] = field(default_factory=list)  # its candidates not proposed yet
    pending: frozenset[str] | None = None  # the goals being pursued
    plans: dict[tuple[str, int], tuple[PlanResult, Any]] = field(default_factory=dict)
    llm_time: float = 0.0
    deadline: float | None = None
    on_round: OnRound | None = None
    clock: Callable[[], float] = time.monotonic
    timings: dict[str, float] = field(default_factory=dict)
    assists: Assists = field(default_factory=Assists)
    success: str | None = None  # the task's intent (None: the task goal)
    stages: Stages = field(default_factory=Stages)  # recovery goals reached and still to reach
    who: str = "the LLM"  # what answers in the records ("the LLM", or a baseline's label)
    baseline: bool = False  # a Baseline answers (no LLM): its restatements are planned as given

    def __post_init__(self) -> None:
        if not self.assists.repair:
            self.method = replace(self.method, repairs=0)
        s = self.session
        self.sem = Semantics(s.domain, {}, {}, strict_costs=False)
        self.task = parse_formula(s.task, self.sem.domain)
        self.search = s.search
        location = self.search.location
        self.memory = SearchMemory(
            self.search,
            self.sem,
            lambda: s.context.belief.facts,
            lambda: s.vocabulary.predicates.get(location, ((),))[0],
            self.task,
            self.assists.unsearched_list,
        )
        self.makeable = Makeable(
            s.domain,
            lambda literal: self.facts(And((literal,))),
            certified(s.problem(self.task, 0)),
        )
        self.check = GoalChecker(
            self.memory,
            lambda goal: self.plan(goal)[0],
            self.facts,
            self.sem,
            self.task,
            lambda: [*self.tried, *self.failed_since],
            self.assists,
            self.makeable,
            self.restates_failure,
        )
        self.start = self.clock()

    def run(self, backend: LLM) -> LoopResult:
        backend = Once(backend)  # an identical request is never sent twice in one run
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
                self.memory.searched_in(parse_formula(rnd.goal, self.sem.domain))
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
                        self.memory.remember(report)
                if report is None or not on_task or asked >= self.max_rounds:
                    return self.end(False, f"no plan for {text}: {rnd.plan.message}")
            else:
                if ep.anomaly is not None and self.task_holds():
                    return self.end(True, f"the task holds: {ep.anomaly.describe()}")
                if ep.anomaly is not None:
                    self.failed_round(ep.anomaly, on_task, bool(ep.completed))
                if ep.anomaly is None or asked >= self.max_rounds:
                    return self.end(False, ep.message or "out of LLM rounds")
                report = self.report = ep.anomaly
                self.memory.remember(report)
            if self.expired():
                return self.stop_at_deadline()
            t = time.perf_counter()
            a = self.assists
            if method(self.method.method).chooser:
                proposal = self.choose(report, backend, asked)
            else:
                proposal = propose(
                    self.situation(report),
                    backend,
                    self.session.vocabulary,
                    self.method,
                    self.check if a.validation or a.search_rewrite else None,
                    self.memory.exhausted() if a.grammar_pruning else (),
                    prune=a.grammar_pruning,
                )
            self.llm_time += time.perf_counter() - t
            self.rounds[-1] = replace(rnd, proposal=proposal)
            self.record()
            if not proposal.ok:
                errors = "; ".join(proposal.parse.errors)
                return self.end(False, f"{self.who} gave no usable goals: " + errors)
            # achieved goals that did not help count as tried, and so do goals whose execution
            # failed (:meth:`failed_round`)
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
            self.success or "",
        )

    def choose(self, report: AnomalyReport, backend: LLM, asked: int) -> Proposal:
        """A choosing method's proposal: for an anomaly ranked before, the next candidate of
        that ranking the checks still accept (no model asked); else the candidates enumerated
        now (:mod:`llmpas.system.candidates`), ranked by the method's chooser, the best one the
        validator accepts proposed and the rest kept."""
        name = self.method.method
        key = "|".join((report.action, *report.args, str(report.constraint), report.reason))
        if self.ranked_for == key and self.ranking:
            found = first_accepted(self.check, [r.goals for r in self.ranking])
            if found is not None:
                i, _ = found
                pick, self.ranking = self.ranking[i], self.ranking[i + 1 :]
                note = "the next candidate of the ranking made for this anomaly before"
                return chosen(name, pick, (), "", self.ranked, [note])
        vocab = self.session.vocabulary
        anchors = anomaly_objects(report, vocab)
        looks = []
        if any(self.search.lost(o) for o in anchors):
            places = vocab.predicates.get(self.search.predicate, ((),))[0]
            looks = [self.memory.look(p) for p in sorted(places)]
        t = time.perf_counter()
        cands = enumerate_goals(
            vocab,
            anchors,
            looks,
            self.makeable,
            lambda g: self.sem.holds(g, self.facts(And((g,)))),
            self.just_failed,
            self.memory.exhausted(),
            self.check.as_goal if self.assists.search_rewrite else lambda g: g,
            self.search.lost,
        )
        self.count("candidates", time.perf_counter() - t)
        if not cands:
            return nothing(name, "no candidate goal set is left (each already true or tried)")
        ranking, exchanges, first_look = rank(
            self.situation(report), backend, cands, self.method, asked
        )
        t = time.perf_counter()
        found = first_accepted(self.check, [r.goals for r in ranking])
        self.count("candidates", time.perf_counter() - t)
        if found is None:
            why = "no candidate goal set passed the checks (unreachable, already true or tried)"
            return nothing(name, why, ranking, exchanges, first_look)
        i, _ = found
        skipped = [f"skipped {r.text}: the checks rejected it" for r in ranking[:i]]
        self.ranked_for, self.ranked, self.ranking = key, ranking, list(ranking[i + 1 :])
        return chosen(name, ranking[i], exchanges, first_look, ranking, skipped)

    def history(self) -> str:
        """What the prompt says was tried: the searches, the goals that did not help, then the
        goals whose execution failed (and why)."""
        lines = self.memory.history()
        lines += [f"- goals {' '.join(sorted(t))} did not help" for t in self.tried]
        lines += [
            f"- goals {' '.join(sorted(t))} could not be achieved: {why}" for t, why in self.failed
        ]
        return "\n".join(lines)

    def failed_round(self, anomaly: AnomalyReport, on_task: bool, acted: bool) -> None:
        """A round's execution failed: its goal is the one that just failed (an answer that
        restates it gets that feedback), and the LLM's goals it pursued count as tried, so that
        the next consultation is told so and cannot propose them again until a
        round carries out a step (``acted``: the state they failed in has changed)."""
        if acted:
            self.failed_since.clear()
        if on_task:
            self.just_failed = frozenset(str(a) for a in conjuncts(self.task))
            return
        if self.pending is None:
            return
        self.just_failed = self.pending
        self.failed_since.add(self.pending)
        if all(self.pending != goals for goals, _ in self.failed):
            self.failed.append((self.pending, f"{anomaly.action} failed ({anomaly.reason})"))

    def restates_failure(self, goals: Sequence[Literal]) -> str:
        """The feedback for an answer whose goals are all of the goal that just failed, when
        its plan repeats the step that failed and nothing the robot believes says why (the
        failure would repeat); "" otherwise (the belief now explains it: replanning may work)."""
        names = frozenset(map(str, goals))
        report = self.report
        if self.baseline or report is None or not names or not names <= self.just_failed:
            return ""  # a baseline's restatement is what it measures: replanning alone
        both = kept_goal(self.task, self.stages.kept, list(goals))
        result, problem = self.plan(both)
        if not (result.solved and self.repeats_unexplained(result, problem)):
            return ""
        step = " ".join((report.action, *report.args))
        return (
            f"{' '.join(sorted(names))} restates the goal that just failed ({step}: "
            f"{report.reason}); planned again, the same step would fail the same way, since "
            "nothing the robot believes has changed; propose what must become true first"
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
        """The task with the recovery goals reached so far kept true
        (:mod:`llmpas.system.recovery`), when that can be planned; else the task alone."""
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
            and not self.memory.is_look(g)
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
        repeats = result.solved and self.repeats_unexplained(result, problem)
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
        changes = [g for g in goals if not self.memory.is_look(g)]
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

    def repeats_unexplained(self, result: PlanResult, problem: Problem) -> bool:
        """The plan contains the step whose failure is the anomaly, and nothing the robot
        believes says why it failed (:func:`repeats_failure`). Nothing tells the planner to
        achieve the new goals before it, so planned together with the task it would fail
        again."""
        if self.report is None or result.plan is None:
            return False
        return repeats_failure(self.sem, self.report, result.plan, problem)


def repeats_failure(sem: Semantics, report: AnomalyReport, plan: Plan, problem: Problem) -> bool:
    """Whether ``plan`` repeats the step whose failure ``report`` is, with nothing the robot
    believes saying why it failed: the report's literal names the action, with no arguments
    (the step's own failure; the same step again), or it is an atom of the domain that the
    problem's facts say holds (a check of the world that the belief has no fact for, such as a
    bowl a lid lies on: ``(accessible bowl)`` is true in the belief; the same action on the same
    objects again, whatever its poses, grasps and bases, which are new in every plan)."""
    c = report.constraint
    if not isinstance(c, Atom):
        return False
    steps = plan.steps
    if not c.args:
        if c.predicate != report.action:
            return False
        return any(s.action == report.action and s.args == report.args for s in steps)
    if not believed(sem, c, problem):
        return False
    action = planned_action(report.action)
    return any(s.action == action and same_objects(s.args, report.args, problem) for s in steps)


def believed(sem: Semantics, c: Atom, problem: Problem) -> bool:
    """Whether ``c``, an atom of the domain, holds in the problem's initial facts."""
    if sem.domain.arity(c.predicate) != len(c.args):
        return False  # a check's own literal (a base motion, a reach), not the domain's
    if any(a not in problem.objects for a in c.args):
        return False
    return sem.holds(c, problem.init)


def same_objects(args: tuple[str, ...], failed: tuple[str, ...], problem: Problem) -> bool:
    """The same arguments where the failed step had an object of the problem's own (a name that
    is its own value: ``cube``, ``bowl``), whatever the others (poses, bases, grasps)."""
    if len(args) != len(failed):
        return False
    return all(a == b for a, b in zip(args, failed, strict=True) if problem.objects.get(b) == b)


def close_loop(
    session: Session,
    llm: LLM | LLMFactory,
    settings: LoopSettings,
    on_round: OnRound | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> LoopResult:
    """Run the closed loop on an open ``session``. ``llm``: a factory of the session (a
    labelled oracle, which reads the world's truth, say), or a backend (read as
    :func:`fixed`); it is built once, when the loop starts.

    ``on_round`` gets the record after every plan-and-execute step and every LLM answer
    (status ``running``), and the final one; when an LLM error, a crash or an interrupt ends
    the loop it gets the rounds run so far with the error recorded, and the exception goes on.
    ``settings.deadline`` (seconds on ``clock``) stops the loop cleanly between steps."""
    factory = as_factory(llm)
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
        backend = factory(session)
        loop.who = who(backend)  # "the LLM", or what answers in its place
        if isinstance(backend, Baseline):  # no LLM: no repairs asked of it
            loop.baseline = True
            loop.method = replace(loop.method, repairs=min(loop.method.repairs, backend.repairs))
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
    except RobotLostError as err:  # not an anomaly: no LLM is asked about it
        loop.record(loop.end(False, f"the robot is gone: {err}", LoopStatus.ROBOT_LOST, str(err)))
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
        self.role = who(inner)
        scorer = getattr(inner, "score", None)
        if callable(scorer):
            self.score = lambda request: self._call(scorer, request)

    def complete(self, request: Request) -> Response:
        response: Response = self._call(self.inner.complete, request)
        return response

    def _call(self, fn: Callable[[Any], Any], request: Any) -> Any:
        left = self.remaining()
        if left <= 0:
            raise _DeadlineReached
        out: list[Any] = []

        def call() -> None:
            try:
                out.append(fn(request))
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


class Once:
    """An identical request is never sent twice in one run: a request (or a scoring request)
    whose key was sent before gets the answer given then (a fixed-seed model would give it
    again, and a round would be wasted asking)."""

    def __init__(self, inner: LLM) -> None:
        self.inner = inner
        self.name = inner.name
        self.role = who(inner)
        self.answers: dict[str, Any] = {}
        self.repeats = 0  # requests answered from what was sent before
        scorer = getattr(inner, "score", None)
        if callable(scorer):
            self.score = lambda request: self._once(scorer, request)

    def complete(self, request: Request) -> Response:
        response: Response = self._once(self.inner.complete, request)
        return response

    def _once(self, fn: Callable[[Any], Any], request: Any) -> Any:
        key = request.key()
        if key in self.answers:
            self.repeats += 1
            return self.answers[key]
        self.answers[key] = answer = fn(request)
        return answer


def who(backend: object) -> str:
    """Who answers goal requests, in the loop's messages: ``the LLM``, unless the backend says
    it is something else (a labelled oracle, the replan baseline), so that their failures are
    not called the LLM's."""
    return str(getattr(backend, "role", "") or "the LLM")


__all__ = [
    "LLMFactory",
    "LLMFor",
    "LoopSettings",
    "Once",
    "as_factory",
    "close_loop",
    "counted",
    "execute",
    "fixed",
    "plan",
    "repeats_failure",
    "who",
]
