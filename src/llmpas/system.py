"""The closed loop of LLM-PAS: plan -> execute -> on an anomaly, reason -> validate -> replan from
the believed state with the new goals (and the task goals when they can be planned together) ->
resume, for a bounded number of rounds.

The belief carries over between rounds (what the robot saw while recovering is what lets it
finish the task); the world's truth is never read, except by the labelled oracle.

One loop serves every world: a world session implements :class:`LoopWorld` (the household:
:class:`~llmpas.worlds.household.loop_adapter.HouseholdLoopWorld`, run by :func:`run_loop`;
PyBullet: :mod:`llmpas.worlds.pybullet.loop`) and :func:`close_loop` runs it.
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
from typing import Any, Protocol

from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Belief
from llmpas.execution.executor import Episode
from llmpas.files import atomic_write
from llmpas.language.domain import Domain
from llmpas.language.logic import And, Atom, Formula, Not, atoms_of
from llmpas.language.problem import parse_formula
from llmpas.language.semantics import Semantics
from llmpas.planning import PlanResult
from llmpas.reasoning.goals import GoalParse, GoalStatus, Literal, Vocabulary
from llmpas.reasoning.llm import LLM, LLMError, Request, Response
from llmpas.reasoning.methods import MethodConfig, Proposal, Situation, propose, rejected
from llmpas.safetext import fenced, printable
from llmpas.worlds.household.loop_adapter import HouseholdLoopWorld
from llmpas.worlds.household.reasoning import Oracle
from llmpas.worlds.household.run import RunConfig, scenario_path
from llmpas.worlds.household.scenario import Scenario, load_scenario
from llmpas.worlds.household.sim import HouseholdWorld


@dataclass(frozen=True)
class LoopSettings:
    """How the loop reasons, in every world (a world's ``LoopConfig`` adds how it runs)."""

    method: MethodConfig = field(default_factory=MethodConfig)
    max_rounds: int = 3  # LLM consultations at most
    deadline: float | None = None  # seconds for the whole loop (checked between its steps)

    def __post_init__(self) -> None:
        if self.max_rounds < 0:
            raise ValueError(f"max_rounds must be >= 0, got {self.max_rounds}")
        if self.deadline is not None and not (math.isfinite(self.deadline) and self.deadline > 0):
            raise ValueError(f"deadline must be a positive number of seconds, got {self.deadline}")


@dataclass(frozen=True)
class LoopConfig(LoopSettings):
    run: RunConfig = field(default_factory=RunConfig)


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
    success: bool  # household: the robot believes the task done; PyBullet: judged in the truth
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
            "rounds": [r.to_json() for r in self.rounds],
        }

    def save(self, path: str | Path) -> Path:
        return atomic_write(path, json.dumps(self.to_json(), indent=2))


class LoopWorld(Protocol):
    """What the closed loop needs from one scenario's world session. Its belief carries over
    between rounds; nothing here reads the world's truth."""

    @property
    def name(self) -> str: ...  # the scenario's name

    @property
    def task(self) -> str: ...  # the task goal, as PDDL text

    @property
    def domain(self) -> Domain: ...

    @property
    def belief(self) -> Belief: ...

    @property
    def vocabulary(self) -> Vocabulary: ...  # the goal predicates and their arguments

    def plan(self, goal: Formula | str, index: int) -> tuple[PlanResult, Any]:
        """Plan ``goal`` from the current belief, in round ``index``: (result, problem)."""
        ...

    def execute(self, plan: PlanResult, problem: Any) -> Episode | None:
        """Execute a plan found by :meth:`plan` (None: there is none)."""
        ...

    def situation(self, report: AnomalyReport, history: str) -> Situation:
        """The prompt's text for an anomaly, with what was tried before."""
        ...

    def search_places(self) -> tuple[str, ...]:
        """Where the robot can look for an object: the arguments of ``(scanned P)``."""
        ...

    def looked_at(self, report: AnomalyReport) -> tuple[str, ...]:
        """The search places a failed detection (a ``Detected`` anomaly) looked at."""
        ...

    def lost(self, obj: str) -> bool:
        """Whether the robot does not know where ``obj`` is (and does not hold it)."""
        ...


LLMFor = Callable[[Callable[[], AnomalyReport | None]], LLM]  # an LLM built on the anomaly
OnRound = Callable[["LoopResult"], object]  # gets the record so far after every step
LLMFactory = Callable[[HouseholdWorld, Callable[[], AnomalyReport | None]], LLM]


def oracle_factory(world: HouseholdWorld, report: Callable[[], AnomalyReport | None]) -> LLM:
    """The **oracle** (upper bound only): answers from the world's true state."""
    return Oracle(world, report)


@dataclass
class _Loop:
    world: LoopWorld
    method: MethodConfig
    max_rounds: int
    rounds: list[Round] = field(default_factory=list)
    report: AnomalyReport | None = None
    tried: list[frozenset[str]] = field(default_factory=list)
    searched: dict[str, set[str]] = field(default_factory=dict)
    plans: dict[tuple[str, int], tuple[PlanResult, Any]] = field(default_factory=dict)
    llm_time: float = 0.0
    deadline: float | None = None
    on_round: OnRound | None = None
    clock: Callable[[], float] = time.monotonic

    def __post_init__(self) -> None:
        self.sem = Semantics(self.world.domain, {}, {}, strict_costs=False)
        self.start = self.clock()

    def run(self, backend: LLM) -> LoopResult:
        task = self.world.task
        goal: Formula | str = task
        text = task
        for _ in range(2 * self.max_rounds + 1):  # the task, then per LLM round: goals + task
            if self.expired():
                return self.stop_at_deadline()
            rnd = self.attempt(goal, text)
            self.rounds.append(rnd)
            self.record()
            ep = rnd.episode
            asked = len([r for r in self.rounds if r.proposal])
            if ep is not None and ep.succeeded:
                if text == task or self.task_holds():
                    return self.end(self.task_holds(), "the task is done")
                self.searched_in(rnd)
                goal, text = task, task  # recovered: back to the task
                continue
            if ep is None:
                # after a recovery that did not settle the anomaly (a search that found
                # nothing), the task cannot be planned yet: the same anomaly goes back to the LLM
                report = self.report
                if report is None or text != task or asked >= self.max_rounds:
                    return self.end(False, f"no plan for {text}: {rnd.plan.message}")
            else:
                if ep.anomaly is None or asked >= self.max_rounds:
                    return self.end(False, ep.message or "out of LLM rounds")
                report = self.report = ep.anomaly
                self.remember(report)
            if self.expired():
                return self.stop_at_deadline()
            sit = self.world.situation(report, self.history())
            t = time.perf_counter()
            proposal = propose(
                sit, backend, self.world.vocabulary, self.method, self.check, self.exhausted()
            )
            self.llm_time += time.perf_counter() - t
            self.rounds[-1] = replace(rnd, proposal=proposal)
            self.record()
            if not proposal.ok:
                errors = "; ".join(proposal.parse.errors)
                return self.end(False, "the LLM gave no usable goals: " + errors)
            self.tried.append(frozenset(map(str, proposal.goals)))
            goal, text = self.next_goal(proposal)
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
            self.world.name,
            success,
            rounds,
            message,
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
            self.plans[key] = self.world.plan(goal, len(self.rounds))
        return self.plans[key]

    def attempt(self, goal: Formula | str, text: str) -> Round:
        result, problem = self.plan(goal)
        return Round(text, result, self.world.execute(result, problem))

    def task_holds(self) -> bool:
        """Whether the robot believes the task done."""
        task = parse_formula(self.world.task, self.sem.domain)
        return self.sem.holds(task, self.world.belief.facts)

    def next_goal(self, proposal: Proposal) -> tuple[Formula, str]:
        """The new goals with the task goals they do not contradict, when that can be planned;
        else the new goals alone (the task is planned again once they are achieved)."""
        new = list(proposal.goals)
        task = parse_formula(self.world.task, self.sem.domain)
        negated = {g.arg for g in new if isinstance(g, Not)}
        keep = [a for a in atoms_of(task) if a not in negated and a not in new]
        both = And((*new, *keep))
        if self.plan(both)[0].solved:
            return both, str(both)
        alone = And(tuple(new))
        return alone, str(alone)

    def check(self, parse: GoalParse) -> GoalParse:
        """Already-true goals are dropped; repeats of exhausted searches and of attempts that
        did not help, and unreachable goals, are rejected with feedback."""
        raw = parse.goals
        parse = self.drop_true(self.as_searches(parse))
        if not parse.ok:
            return replace(parse, rejected=raw)
        errors = []
        bad = []
        for g in parse.goals:
            if isinstance(g, Atom) and g.predicate == "scanned":
                for obj, regions in self.searched.items():
                    if g.args[0] in regions:
                        bad.append(g)
                        errors.append(
                            f"{g}: {g.args[0]} was already searched for {obj} from "
                            "several positions without finding it; look elsewhere"
                            + self.not_searched(obj, regions)
                        )
        if errors:
            culprits = [r for r in raw if self.as_search(r) in bad]
            return rejected(parse, GoalStatus.REPEATED, errors, culprits)
        parse = self.reachable(parse)
        if not parse.ok:
            culprits = [r for r in raw if self.as_search(r) in parse.rejected]
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
        for obj, regions in self.searched.items():
            if self.world.lost(obj):
                for place in sorted(regions):
                    out += [Atom("scanned", (place,)), Atom("on", (obj, place))]
        return tuple(out)

    def as_searches(self, parse: GoalParse) -> GoalParse:
        """``(on X P)`` for a lost object X and a place P the robot can search is read as the
        hypothesis it states: look at P, ``(scanned P)`` (no plan can put X anywhere before it
        is found)."""
        goals: list[Literal] = []
        notes = list(parse.notes)
        for g in parse.goals:
            search = self.as_search(g)
            if search != g and isinstance(g, Atom):
                notes.append(f"read {g} as {search}: where {g.args[0]} is, is unknown")
            if search not in goals:
                goals.append(search)
        if goals == list(parse.goals):
            return parse
        return GoalParse(parse.status, tuple(goals), parse.errors, parse.source, tuple(notes))

    def as_search(self, g: Literal) -> Literal:
        """``(scanned P)`` for ``(on X P)`` with X lost and P a place to search; else ``g``."""
        lost = isinstance(g, Atom) and g.predicate == "on" and self.world.lost(g.args[0])
        if lost and isinstance(g, Atom) and g.args[1] in self.world.search_places():
            return Atom("scanned", (g.args[1],))
        return g

    def drop_true(self, parse: GoalParse) -> GoalParse:
        """Goals the robot believes already hold are dropped (all of them: rejected)."""
        true = [g for g in parse.goals if self.sem.holds(g, self.world.belief.facts)]
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
        lost = [a for a in getattr(atom, "args", ()) if self.world.lost(a)]
        if lost:
            text += (
                f" ({', '.join(lost)}: location unknown; find it first with a goal "
                "(scanned PLACE) for a place not searched yet)"
            )
        return text

    def remember(self, report: AnomalyReport) -> None:
        """A failed detection: the places it looked at are searched for its object."""
        if report.constraint_name == "Detected":
            obj = report.constraint.args[0] if isinstance(report.constraint, Atom) else ""
            self.searched.setdefault(str(obj), set()).update(self.world.looked_at(report))

    def searched_in(self, rnd: Round) -> None:
        """A search goal reached while an object is still lost: that place is searched."""
        lost = [o for o in self.searched if self.world.lost(o)]
        for goal in atoms_of(parse_formula(rnd.goal, self.sem.domain)):
            if goal.predicate == "scanned":
                for obj in lost:
                    self.searched[obj].add(goal.args[0])

    def not_searched(self, obj: str, regions: set[str]) -> str:
        rest = [p for p in self.world.search_places() if p not in regions]
        return f" (not searched yet: {', '.join(rest)})" if rest else ""

    def history(self) -> str:
        lines = []
        for obj, regions in self.searched.items():
            lines.append(f"- {obj} was not found on {', '.join(sorted(regions))}")
            rest = [p for p in self.world.search_places() if p not in regions]
            lines.append(f"- places not searched yet for {obj}: {', '.join(rest)}")
        lines += [f"- goals {' '.join(sorted(t))} did not help" for t in self.tried]
        return "\n".join(lines)


def close_loop(
    world: LoopWorld,
    llm: LLM | LLMFor,
    settings: LoopSettings,
    on_round: OnRound | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> LoopResult:
    """Run the closed loop on ``world``. ``llm`` is a backend, or a function of the current
    anomaly that builds one (the oracle).

    ``on_round`` gets the record after every plan-and-execute step and every LLM answer
    (status ``running``), and the final one; when an LLM error, a crash or an interrupt ends
    the loop it gets the rounds run so far with the error recorded, and the exception goes on.
    ``settings.deadline`` (seconds on ``clock``) stops the loop cleanly between steps."""
    loop = _Loop(
        world,
        settings.method,
        settings.max_rounds,
        deadline=settings.deadline,
        on_round=on_round,
        clock=clock,
    )
    try:
        backend = llm if isinstance(llm, LLM) else llm(lambda: loop.report)
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


def run_loop(
    scenario: Scenario | str | Path,
    llm: LLM | LLMFactory,
    config: LoopConfig | None = None,
    on_round: OnRound | None = None,
) -> LoopResult:
    """Run a household scenario with LLM recovery. ``llm`` is a backend, or a factory that gets
    the world and the current anomaly (how the oracle is built); ``on_round``: see
    :func:`close_loop`."""
    config = config or LoopConfig()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario_path(str(scenario)))
    world = HouseholdLoopWorld.open(scenario, config.run)
    if isinstance(llm, LLM):
        return close_loop(world, llm, config, on_round)
    factory = llm
    return close_loop(world, lambda report: factory(world.sim, report), config, on_round)


__all__ = [
    "LLMFactory",
    "LLMFor",
    "LoopConfig",
    "LoopResult",
    "LoopSettings",
    "LoopStatus",
    "LoopWorld",
    "Round",
    "close_loop",
    "loop_markdown",
    "oracle_factory",
    "run_loop",
    "save_loop",
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


def save_loop(result: LoopResult, folder: str | Path) -> list[Path]:
    """``loop.json``, ``loop.md`` and, per round, the episode report and subtree XML."""
    from llmpas.execution.report import save_episode

    out = Path(folder)
    files = save_records(result, out)
    for i, rnd in enumerate(result.rounds):
        if rnd.episode is not None:
            files += save_episode(rnd.episode, out / f"round{i}", title=f"Round {i}: {rnd.goal}")
    return files


def save_records(result: LoopResult, folder: str | Path) -> list[Path]:
    """``loop.json`` and ``loop.md`` (atomically): what the loop calls after every round."""
    out = Path(folder)
    return [result.save(out / "loop.json"), atomic_write(out / "loop.md", loop_markdown(result))]
