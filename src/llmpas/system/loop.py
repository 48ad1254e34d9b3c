"""Round control: plan -> execute -> on an anomaly (:mod:`~llmpas.system.anomaly_memory`), consult
the reasoning method (:mod:`~llmpas.system.consult`, its answers checked by a
:class:`~llmpas.system.goal_checks.GoalChecker`, its searches remembered by a
:class:`~llmpas.system.search_memory.SearchMemory`) -> replan from the believed state with the next
goal (:mod:`~llmpas.system.next_goal`: the new goals, and the task goals when they can be planned
together) -> resume, for a bounded number of rounds (:func:`close_loop`).

The loop takes its LLM in one shape: a factory of the session
(:data:`~llmpas.system.llm_factories.LLMFactory`), called once when the loop starts.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from llmpas.errors import RobotLostError
from llmpas.language.logic import Formula
from llmpas.language.problem import parse_formula
from llmpas.language.semantics import Semantics
from llmpas.planning.invariants import Invariants
from llmpas.reasoning.goal_reading import Literal
from llmpas.reasoning.llm import LLM, Baseline, LLMError
from llmpas.system.acting import Acting, counted, execute, plan
from llmpas.system.anomaly_memory import Anomaly, Tried, repeats_failure, unknown_place
from llmpas.system.consult import Consultation
from llmpas.system.llm_factories import (
    ByDeadline,
    DeadlineReached,
    LLMFactory,
    LLMFor,
    Once,
    Watched,
    as_factory,
    fixed,
    who,
)
from llmpas.system.next_goal import NextGoal
from llmpas.system.observe import Observer
from llmpas.system.records import LoopResult, LoopStatus, OnRound, Round
from llmpas.system.search_memory import SearchMemory
from llmpas.system.settings import LoopSettings
from llmpas.system.sweep import Sweep
from llmpas.worlds.api import Session


class Consulting(Exception):
    """Raised by a probing loop where it would consult the method: the anomaly it would ask
    about (:mod:`llmpas.system.probe`)."""

    def __init__(self, anomaly: Anomaly) -> None:
        super().__init__(anomaly.text)
        self.anomaly = anomaly


@dataclass
class _Loop:
    """The rounds of one run: what was planned and executed, the anomaly being resolved and
    what was tried for it, the consultation, and the next goal."""

    session: Session
    settings: LoopSettings
    rounds: list[Round] = field(default_factory=list)
    anomaly: Anomaly | None = None
    llm_time: float = 0.0
    on_round: OnRound | None = None
    clock: Callable[[], float] = time.monotonic
    who: str = "the LLM"  # what answers in the records ("the LLM", or a baseline's label)
    baseline: bool = False  # a Baseline answers (no LLM): its restatements are planned as given
    sweep: Sweep | None = None  # the search the last consultation yields, while it goes on
    note: str = ""  # what the page says of the next round (a sweep's look)
    observer: Observer | None = None  # a viewer told of every step (None: nobody watches)
    probing: bool = False  # stop at the first consultation (:class:`Consulting`), asking nobody

    def __post_init__(self) -> None:
        s, settings = self.session, self.settings
        method = settings.method
        if not settings.assists.repair:
            method = replace(method, repairs=0)
        self.max_rounds = settings.max_rounds
        self.deadline = settings.deadline
        self.sem = Semantics(s.domain, {}, {}, strict_costs=False)
        self.task = parse_formula(s.task, self.sem.domain)
        self.search = s.search
        self.acting = Acting(s, lambda: len(self.rounds), observer=self.observer)
        location = self.search.location
        self.memory = SearchMemory(
            self.search,
            self.sem,
            lambda: s.context.belief.facts,
            lambda: s.vocabulary.predicates.get(location, ((),))[0],
            self.task,
            settings.assists.unsearched_list,
        )
        self.tried = Tried()
        invariants = Invariants.of(s.domain, s.problem(self.task, 0).streams)
        self.goals = NextGoal(
            self.acting, self.sem, s.task, self.memory, settings.success, invariants=invariants
        )
        self.consult = Consultation(
            self.acting,
            self.sem,
            self.task,
            self.memory,
            self.tried,
            self.restates_failure,
            method,
            settings.assists,
            settings.success,
            invariants=invariants,
        )
        self.start = self.clock()

    def answered_by(self, backend: LLM) -> None:
        """Who answers: "the LLM", or a baseline (no LLM: no repairs asked of it)."""
        self.who = who(backend)
        if isinstance(backend, Baseline):
            self.baseline = True
            m = self.consult.method
            self.consult.method = replace(m, repairs=min(m.repairs, backend.repairs))

    def run(self, backend: LLM) -> LoopResult:
        backend = Once(backend)  # an identical request is never sent twice in one run
        seen = self.observer
        if seen is not None:  # each request told when sent and when answered
            backend = Watched(
                backend,
                lambda request: seen.prompted(len(self.rounds) - 1, request),
                lambda request, response: seen.replied(len(self.rounds) - 1, request, response),
            )
        goal, text = self.goals.task()
        on_task = True  # the round plans the task (with the recovery goals kept), not goals
        steps = 2 * self.max_rounds + 1  # the task, then per LLM round: goals + task
        while steps > 0:
            steps -= 1
            if self.expired():
                return self.stop_at_deadline()
            rnd = self.acting.attempt(goal, text)
            if self.note:
                rnd, self.note = replace(rnd, note=self.note), ""
            self.rounds.append(rnd)
            self.record()
            ep = rnd.episode
            asked = len([r for r in self.rounds if r.proposal])
            if ep is not None and ep.succeeded:
                if on_task or self.goals.holds():
                    return self.end(*self.goals.verdict())
                self.goals.reached(rnd, self.tried.pending)
                if self.goals.stages.queue:  # the LLM's next goals, in the order it wrote them
                    goal, text = self.goals.answer(self.goals.stages.queue, self.anomaly)
                    steps += 1
                    continue
                look = self.next_look()  # a sweep goes on while the object is not seen
                if look is not None:
                    goal, text = look
                    steps += 1
                    continue
                self.sweep = None
                self.tried.in_vain()  # achieved; if the task fails again, it did not help
                goal, text = self.goals.task()  # recovered: back to the task
                on_task = True
                continue
            self.sweep = None  # a look that failed, or the task again: the sweep is over
            if ep is None:
                # after a recovery that did not settle the anomaly (a search that found
                # nothing), the task cannot be planned yet: the same anomaly goes back to the LLM
                anomaly = self.anomaly
                if anomaly is None and on_task:
                    anomaly = self.anomaly = self.unknown_place()  # the task names a lost object
                    if anomaly is not None:
                        self.memory.remember(anomaly.report)
                if anomaly is None or not on_task or asked >= self.max_rounds:
                    return self.end(False, f"no plan for {text}: {rnd.plan.message}")
            else:
                if ep.anomaly is not None and self.goals.holds():
                    return self.end(True, f"the task holds: {ep.anomaly.describe()}")
                failed = None if ep.anomaly is None else Anomaly(ep.anomaly)
                if failed is not None:
                    self.tried.failed_round(failed, self.task, on_task, bool(ep.completed))
                if failed is None or asked >= self.max_rounds:
                    return self.end(False, ep.message or "out of LLM rounds")
                anomaly = self.anomaly = failed
                self.memory.remember(anomaly.report)
            if self.expired():
                return self.stop_at_deadline()
            if self.probing:
                raise Consulting(anomaly)
            t, logged = time.perf_counter(), len(self.consult.check.log)
            proposal = self.consult.ask(anomaly, backend, asked)
            self.llm_time += time.perf_counter() - t
            if self.observer is not None:
                self.observer.answered(len(self.rounds) - 1, proposal)
            checks = tuple(self.consult.check.log[logged:])
            self.rounds[-1] = replace(rnd, proposal=proposal, checks=checks)
            self.record()
            if not proposal.ok:
                errors = "; ".join(proposal.parse.errors)
                return self.end(False, f"{self.who} gave no usable goals: " + errors)
            # achieved goals that did not help count as tried, and so do goals whose execution
            # failed (:meth:`Tried.failed_round`)
            self.tried.pending = frozenset(map(str, proposal.goals))
            self.sweep = self.consult.sweep(anomaly, proposal, self.settings.sweep)
            look = self.next_look()
            made = len(self.goals.substitutions)
            goal, text = look or self.goals.answer(list(proposal.goals), self.anomaly)
            if len(self.goals.substitutions) > made:
                self.note = "substituted: " + self.goals.substitutions[-1].describe()
            on_task = False
        return self.end(False, f"not done after {self.max_rounds} LLM rounds")

    def next_look(self) -> tuple[Formula, str] | None:
        """The sweep's next place (:meth:`NextGoal.look`); the page's note for its round."""
        if self.sweep is None or not self.search.lost(self.sweep.obj):
            return None
        look = self.goals.look(self.sweep, self.anomaly)
        if look is not None:
            self.note = self.sweep.note()
        return look

    def unknown_place(self) -> Anomaly | None:
        """The task names an object the robot cannot place (:func:`unknown_place`)."""
        s = self.search
        belief = self.session.context.belief.facts
        return unknown_place(self.task, s.lost, s.location, s.detection, belief)

    def restates_failure(self, goals: Sequence[Literal]) -> str:
        """The feedback for an answer restating the goal that just failed
        (:meth:`NextGoal.restates`); never for a baseline, whose restatement is what it
        measures: replanning alone."""
        if self.baseline:
            return ""
        return self.goals.restates(goals, self.anomaly, self.tried.just_failed)

    def end(
        self,
        success: bool,
        message: str,
        status: LoopStatus | None = None,
        error: str = "",
    ) -> LoopResult:
        return LoopResult(
            self.session.name,
            success,
            tuple(self.rounds),
            message,
            timings={**self.session.timings, **self.acting.timings},
            llm_time=self.llm_time,
            status=status,
            error=error,
            task=self.goals.task_text if self.goals.substitutions else "",
            substitutions=tuple(x.describe() for x in self.goals.substitutions),
            plans=dict(self.acting.statuses),
        )

    def record(self, result: LoopResult | None = None) -> None:
        """Hand the record so far (or the final one) to ``on_round`` (which saves it) and to
        the observer."""
        if self.on_round is None and self.observer is None:
            return
        running = f"running: {len(self.rounds)} rounds so far"
        record = result or self.end(False, running, LoopStatus.RUNNING)
        if self.on_round is not None:
            self.on_round(record)
        if self.observer is not None:
            self.observer.recorded(record)

    def expired(self) -> bool:
        return self.deadline is not None and self.clock() - self.start >= self.deadline

    def remaining(self) -> float:
        return math.inf if self.deadline is None else self.deadline - (self.clock() - self.start)

    def stop_at_deadline(self) -> LoopResult:
        spent = self.clock() - self.start
        message = f"deadline: stopped after {spent:.1f} s (deadline {self.deadline:g} s)"
        return self.end(False, message, LoopStatus.DEADLINE, message)


def close_loop(
    session: Session,
    llm: LLM | LLMFactory,
    settings: LoopSettings,
    on_round: OnRound | None = None,
    clock: Callable[[], float] = time.monotonic,
    observer: Observer | None = None,
) -> LoopResult:
    """Run the closed loop on an open ``session``. ``llm``: a factory of the session (a
    labelled oracle, which reads the world's truth, say), or a backend (read as
    :func:`~llmpas.system.llm_factories.fixed`); it is built once, when the loop starts.

    ``on_round`` gets the record after every plan-and-execute step and every LLM answer
    (status ``running``), and the final one; when an LLM error, a crash or an interrupt ends
    the loop it gets the rounds run so far with the error recorded, and the exception goes on.
    ``settings.deadline`` (seconds on ``clock``) stops the loop cleanly between steps.
    ``observer`` (:class:`~llmpas.system.observe.Observer`) is told of every plan, tick,
    round, consultation and record (None: nobody watches, nothing is built for a viewer)."""
    factory = as_factory(llm)
    loop = _Loop(session, settings, on_round=on_round, clock=clock, observer=observer)
    if observer is not None:
        observer.started(session)
    try:
        backend = factory(session)
        loop.answered_by(backend)
        if settings.deadline is not None:
            backend = ByDeadline(backend, loop.remaining)
        result = loop.run(backend)
    except DeadlineReached:
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
