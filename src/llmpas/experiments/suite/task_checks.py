"""The checks of one task that need runs: the oracle's run (it can be planned, its events fire,
its anomaly has the task's category, the oracle resolves it), the effective goal sets, the replan
baseline and an irrelevant goal (for tasks marked ``measures_llm``), and the optimal resolution
``l_gt`` is compared with."""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Any

from llmpas.experiments.effective import as_search, lost_object
from llmpas.experiments.suite.judge import (
    first_anomaly,
    judge,
    resolution_length,
    run_traced,
    unknown_start,
)
from llmpas.experiments.suite.task_files import (
    ANOMALY_KINDS,
    UNMODELLED_CAUSES,
    Category,
    SuiteError,
    SuiteTask,
)
from llmpas.experiments.suite.truth import holds_in_truth
from llmpas.experiments.worlds import LoopConfig
from llmpas.language.logic import Atom, Formula, Not
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig
from llmpas.planning.config import Algorithm
from llmpas.planning.result import PlanStatus
from llmpas.reasoning.llm import LLM, Request, Response
from llmpas.reasoning.replan import Replan
from llmpas.system import LoopResult, LoopSettings, close_loop
from llmpas.worlds.household.household_decomposition import ExplorationConfig
from llmpas.worlds.household.household_oracle import oracle as household_oracle
from llmpas.worlds.household.household_plugin import HouseholdSession
from llmpas.worlds.household.sim import HouseholdWorld
from llmpas.worlds.household.state import PROCESS_EFFECTS

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Issue:
    """One mistake in a task file: ``file: field: message``."""

    source: str
    field: str
    message: str

    def __str__(self) -> str:
        return f"{self.source}: {self.field}: {self.message}"


def issue_from(error: SuiteError, source: str) -> Issue:
    """Split a ``file: field: message`` error line."""
    text = str(error)
    if text.startswith(f"{source}: "):
        text = text[len(source) + 2 :]
    where, sep, message = text.partition(": ")
    return Issue(source, where, message) if sep else Issue(source, "file", text)


HASH_SEEDS = (0, 1, 2, 3)
"""The planner's tie-breaking depends on Python's string hashing (set iteration order), so the
resolution it finds can differ between processes. ``l_gt`` is the SHORTEST resolution over runs
with these fixed ``PYTHONHASHSEED`` values, which makes it reproducible."""


@dataclass(frozen=True)
class OracleRun:
    """What one oracle run of a task showed: mistakes other than ``l_gt``, and the resolution
    length (None when the oracle could not resolve the task)."""

    source: str
    issues: tuple[Issue, ...]
    length: int | None
    hash_seed: str = ""
    replan: str = ""  # the replan baseline's verdict ("": not run)
    notes: tuple[Issue, ...] = ()  # remarks that are not errors
    optimal: int | None = None  # the resolution length with an optimal search (None: not run)


def oracle_run(
    task: SuiteTask, config: LoopConfig | None = None, *, judge_sets: bool = False
) -> OracleRun:
    """Run the task with the oracle and check that the task can be planned, every event fires,
    an anomaly of the task's category happens, and the oracle's resolution completes the task on
    the true state. ``judge_sets``: also check the effective sets (:func:`effective_issues`), run
    the replan baseline (:func:`replan_issues`) and an irrelevant goal
    (:func:`irrelevant_issues`)."""
    config = config or LoopConfig()
    run = _oracle_run(task, config)
    if not judge_sets:
        return run
    extra, notes = effective_issues(task, config)
    replan, why = replan_issues(task, config)
    irrelevant = irrelevant_issues(task, config)
    issues = (*run.issues, *extra, *why, *irrelevant)
    optimal = optimal_resolution(task, config) if run.length is not None else None
    return replace(run, issues=issues, replan=replan, notes=tuple(notes), optimal=optimal)


def _oracle_run(task: SuiteTask, config: LoopConfig) -> OracleRun:
    import os

    src = task.source
    seed = os.environ.get("PYTHONHASHSEED", "")
    traced = run_traced(task, household_oracle, config)
    result, world = traced.result, traced.world
    first_round = result.rounds[0] if result.rounds else None
    start = unknown_start(result, task)  # the object's whereabouts unknown: the loop searches
    if first_round is None or (first_round.plan.plan is None and start is None):
        why = first_round.plan.message if first_round else "no round ran"
        if first_round is not None and first_round.plan.status in NO_VERDICT:
            message = _no_verdict(first_round.plan.status, "the task from the believed state")
        else:
            message = "unreachable: no plan from the believed initial state"
        return OracleRun(src, (Issue(src, "task.goal", f"{message} ({why})"),), None, seed)
    issues: list[Issue] = []
    for i, e in enumerate(task.scenario.events):
        logged = [
            x for x in world.fired() if x.kind == "event" and x.args == (e.object, str(e.after))
        ]
        if not logged:
            issues.append(
                Issue(
                    src,
                    f"events[{i}].after",
                    f"never triggers: {e.after} does not happen in the run "
                    f"({world.successes(e.after.skill)} successful {e.after.skill} calls)",
                )
            )
        elif not any(x.ok for x in logged):
            issues.append(Issue(src, f"events[{i}]", f"never applies: {logged[0].message}"))
    first = first_anomaly(result, task)
    if first is None:
        ep = result.rounds[0].episode
        status = ep.status.value if ep is not None else "no episode"
        issues.append(
            Issue(src, "events", f"no anomaly: the plan for the task runs without one ({status})")
        )
        return OracleRun(src, tuple(issues), None, seed)
    c = first[1].constraint
    if anomaly_category(c, world) is not task.category:
        want = " or ".join(
            f"(not ({p} ...))" if neg else f"({p} ...)"
            for p, neg in sorted(ANOMALY_KINDS[task.category])
        )
        causes = sorted(UNMODELLED_CAUSES[task.category])
        if causes:
            want += f", or a failed process because of {', '.join(causes)}"
        issues.append(
            Issue(
                src,
                "judge.category",
                f"{task.category.value} expects a violated {want}, but the anomaly is {c}",
            )
        )
    if not result.believed or not holds_in_truth(task.success, world.truth):
        why = result.message if not result.believed else "the true final state does not satisfy it"
        limit = planner_limit(result) if not result.believed else None
        verdict = (
            "unreachable: the oracle's resolution fails"
            if limit is None
            else _no_verdict(limit, "the oracle's resolution")
        )
        issues.append(Issue(src, "judge.success", f"{verdict}: {why}"))
        return OracleRun(src, tuple(issues), None, seed)
    return OracleRun(src, tuple(issues), resolution_length(result, task), seed)


NO_VERDICT = (PlanStatus.TIMEOUT, PlanStatus.LIMIT, PlanStatus.CRASHED, PlanStatus.ERROR)
"""Plan statuses that are no verdict on reachability: a time limit (a safety net that depends on
the machine's load), a counted limit, a crashed or failing planner. validate-data reports them
as such, never as "unreachable"."""


def _no_verdict(status: PlanStatus, what: str) -> str:
    if status is PlanStatus.TIMEOUT:
        return (
            f"time-out: the planner's time limit fired while planning {what} (no verdict on "
            "reachability: raise --max-time, or run on a less loaded machine)"
        )
    return f"planner {status.value}: no verdict on reachability while planning {what}"


def planner_limit(result: LoopResult) -> PlanStatus | None:
    """The last plan of the run that ended without a verdict (a time-out, a counted limit, a
    crash), when the run's last planning or a goal check ended so; None: every planning of the
    run came to a verdict (a plan, or a proof that there is none)."""
    statuses = [r.plan.status for r in result.rounds]
    if statuses and statuses[-1] in NO_VERDICT:
        return statuses[-1]
    if "not judged:" in result.message:  # a goal check whose planning had no verdict
        text = result.message.lower()
        if "crash" in text:
            return PlanStatus.CRASHED
        return PlanStatus.TIMEOUT if "time" in text or "exceeded" in text else PlanStatus.LIMIT
    return None


def anomaly_category(c: Atom | Not, world: HouseholdWorld) -> Category | None:
    """The category of an anomaly that violated ``c``: by the constraint (:data:`ANOMALY_KINDS`)
    or, for a process that failed for a cause the domain does not model, by the reason of its
    first failure (:data:`UNMODELLED_CAUSES`). None: no category accepts it."""
    atom = c.arg if isinstance(c, Not) else c
    if isinstance(atom, Atom):
        kind = (atom.predicate, isinstance(c, Not))
        for category, kinds in ANOMALY_KINDS.items():
            if kind in kinds:
                return category
    if not (isinstance(c, Atom) and c.predicate in PROCESS_EFFECTS and not c.args):
        return None
    failed = [e for e in world.skill_calls("process") if not e.ok]
    if not failed:
        return None
    return next((k for k, v in UNMODELLED_CAUSES.items() if failed[0].reason in v), None)


class _FirstAnswer:
    """Answers the first goal request with ``answer`` and everything else as ``inner`` (the
    oracle): an effective set proposed at the anomaly, the rest of the run ideal."""

    name = "effective-set"

    def __init__(self, answer: str, inner: LLM) -> None:
        self.answer = answer
        self.inner = inner
        self.used = False

    def complete(self, request: Request) -> Response:
        if request.tag == "goals" and not self.used:
            self.used = True
            return Response(self.answer, model=self.name)
        try:
            return self.inner.complete(request)
        except Exception as e:  # the follow-up failed: the run ends unresolved, and says why
            log.warning("the oracle could not answer after an effective set: %s", e)
            return Response(f"(and) ; the oracle failed: {type(e).__name__}", model=self.name)


def effective_issues(
    task: SuiteTask, config: LoopConfig | None = None
) -> tuple[list[Issue], list[Issue]]:
    """Each effective set, proposed as the first answer at the first anomaly (no repairs, the
    oracle answering any later anomaly): (issues, notes). An issue when the loop does not
    accept it unchanged (modulo its search rewrite) or cannot plan it from the anomaly state;
    a note when it is planned but the run then does not resolve the task (the loop's or the
    planner's limits, or the set: worth a look, not an error)."""
    config = config or LoopConfig()
    probe = replace(config, method=replace(config.method, repairs=0))
    places = task.search_places()
    issues: list[Issue] = []
    notes: list[Issue] = []
    if not task.effective:
        missing = Issue(task.source, "judge.effective", "missing: list the effective goal sets")
        return [missing], []
    for i, (text, literals) in enumerate(zip(task.effective, task.effective_sets(), strict=True)):
        where = f"judge.effective[{i}]"

        def factory(session: HouseholdSession, text: str = text) -> LLM:
            return _FirstAnswer(text, household_oracle(session))

        traced = run_traced(task, factory, probe)
        result = traced.result
        first = first_anomaly(result, task)
        proposals = [r.proposal for r in result.rounds if r.proposal is not None]
        if first is None or not proposals:
            continue  # no anomaly: the oracle run reports it
        lost = lost_object(first[1].constraint)
        p = proposals[0]
        want = {as_search(g, lost, places) for g in literals}
        if not p.ok:
            why = "; ".join(p.parse.errors) or p.parse.status.value
            issues.append(Issue(task.source, where, f"{text}: rejected at the anomaly: {why}"))
        elif {as_search(g, lost, places) for g in p.goals} != want:
            shown = " ".join(map(str, p.goals))
            issues.append(Issue(task.source, where, f"{text}: the loop changes it to {shown}"))
        elif not result.believed or not holds_in_truth(task.success, traced.world.truth):
            why = result.message if not result.believed else "the true final state disagrees"
            notes.append(
                Issue(task.source, where, f"{text}: planned, but the task is not resolved: {why}")
            )
    return issues, notes


def replan_issues(task: SuiteTask, config: LoopConfig | None = None) -> tuple[str, list[Issue]]:
    """The replan baseline's verdict on the task, and an issue when the task is marked
    ``measures_llm`` but replanning the task alone resolves it."""
    j = judge(task, Replan(task.scenario.goal), config or LoopConfig())
    if task.measures_llm and j.success:
        why = "the replan baseline (the task goal restated) resolves it: the cause is in the belief"
        return j.verdict.value, [Issue(task.source, "judge.measures_llm", why)]
    return j.verdict.value, []


OPTIMAL_SEARCH = "astar(hmax(axioms=approximate_negative), cost_type=one)"
"""The optimal classical search ``l_gt`` is measured with: A* with an admissible heuristic and
unit costs (the number of actions, not the drive distances the default search weighs)."""


class OptimalSession:
    """A household session planned with :data:`OPTIMAL_SEARCH` after the first round (which runs
    into the anomaly as in the oracle's run, so that both resolutions start from the same anomaly
    state). Everything else is the session's own."""

    def __init__(self, inner: HouseholdSession, algorithm: Algorithm = "focused") -> None:
        self.inner = inner
        self.optimal = replace(inner.planner, algorithm=algorithm, search=OPTIMAL_SEARCH)
        self.index = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    @property
    def planner(self) -> PlannerConfig:
        return self.inner.planner if self.index == 0 else self.optimal

    def problem(self, goal: Formula | str, index: int) -> Problem:
        self.index = index
        return self.inner.problem(goal, index)


def optimal_resolution(
    task: SuiteTask, config: LoopConfig | None = None, algorithm: Algorithm = "focused"
) -> int | None:
    """The resolution length of the oracle's run when every plan after the first round is
    found by an optimal search (None: that run did not resolve the task)."""
    config = config or LoopConfig()
    inner = HouseholdSession.open(task.scenario, config.options, ExplorationConfig())
    session = OptimalSession(inner, algorithm)
    settings = LoopSettings(method=config.method, max_rounds=config.max_rounds)
    result = close_loop(session, household_oracle(inner), settings)
    if not result.success or not holds_in_truth(task.success, inner.sim.truth):
        return None
    found = first_anomaly(result, task) is not None
    return resolution_length(result, task) if found else None


class _Always:
    """Answers every request with the same text (an irrelevant goal, say)."""

    name = "irrelevant-goal"

    def __init__(self, answer: str) -> None:
        self.answer = answer

    def complete(self, request: Request) -> Response:
        return Response(self.answer, model=self.name)


def irrelevant_goal(task: SuiteTask) -> str | None:
    """A goal that has nothing to do with the task: open the first drawer that is truly empty
    and closed, not jammed, and named neither by the task, its success condition nor its
    effective sets (None: there is no such drawer)."""
    sc = task.scenario
    named = " ".join((sc.goal, task.success, *task.effective)).lower()
    truth = sc.initial_state()
    for region in sorted(sc.layout.regions):
        if not region.startswith("drawer") or region in named or region in sc.jammed:
            continue
        if truth.objects_in(region) or sc.open.get(region, False):
            continue
        if any(e.region == region for e in sc.events):
            continue
        return f"(and (open {region}))"
    return None


def irrelevant_issues(task: SuiteTask, config: LoopConfig | None = None) -> list[Issue]:
    """A task marked ``measures_llm`` must not be resolved by an irrelevant goal (answered to
    every consultation): if it is, the anomaly's cause is in the belief, and replanning after
    any goal resolves it."""
    goal = irrelevant_goal(task) if task.measures_llm else None
    if goal is None:
        return []
    j = judge(task, _Always(goal), config or LoopConfig())
    if not j.success:
        return []
    why = f"an irrelevant goal {goal} resolves it: the cause is in the belief"
    return [Issue(task.source, "judge.measures_llm", why)]


def check_task(task: SuiteTask, runs: Iterable[OracleRun], *, exact: bool = True) -> list[Issue]:
    """The mistakes the oracle runs of ``task`` showed (each once), and whether ``l_gt`` is the
    shortest resolution they found. ``exact``: the runs cover :data:`HASH_SEEDS`, so the
    shortest must equal ``l_gt``; otherwise it must only not be shorter (fewer runs may miss the
    shortest)."""
    runs = list(runs)
    issues: list[Issue] = []
    for r in runs:
        issues.extend(i for i in r.issues if i not in issues)
    lengths = {f"hash seed {r.hash_seed or 'random'}": r.length for r in runs if r.length}
    optimal = [r.optimal for r in runs if r.optimal is not None]
    if optimal:
        lengths["optimal search"] = min(optimal)
    if lengths:
        shortest = min(lengths.values())
        if shortest < task.l_gt or (exact and shortest != task.l_gt):
            found = ", ".join(f"{n} ({how})" for how, n in lengths.items())
            issues.append(
                Issue(
                    task.source,
                    "judge.l_gt",
                    f"{task.l_gt}, but the shortest resolution the planner finds from the true "
                    f"anomaly state has {shortest} actions (found: {found})",
                )
            )
    return issues
