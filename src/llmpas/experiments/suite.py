"""The household anomaly suite: one TOML file per task, the judge that decides whether a run
resolved its anomaly, and the checks of ``llmpas bench validate-data``.

Format of a task file (``suite/household/*.toml``; see ``suite/README.md``): a household
scenario exactly as :mod:`llmpas.worlds.household.scenario` reads it — the TRUE initial world
(``[[objects]]``, ``[open]``, ``[robot]``), what the robot believes (``[belief]``), the task goal
(``[task] goal``) and the anomaly to inject and when (``[[events]]`` with ``after`` triggers, or a
belief that differs from the truth) — plus one extra table that the scenario parser never sees::

    [judge]
    category = "object-loss"        # object-loss | action-blocking | state-change
    l_gt = 7                        # ground-truth shortest resolution length (actions), >= 1
    success = "(and (On cube bowl))" # optional: checked on the TRUE final state
                                    #   (default: the task goal); and/or/not over
                                    #   On/2, Holding/1, Open/1, Dirty/1, Cleaned/1,
                                    #   Cooked/1, Heated/1, Cooled/1 (no Scanned: it is not
                                    #   a property of the world)
    effective = ["(and (scanned drawer3))", "(and (open drawer3))"]
                                    # the goal sets an expert would accept as resolving the
                                    #   anomaly (see experiments.effective for the rule)
    measures_llm = true             # optional (default false): the task belongs to the suite
                                    #   that measures the LLM: replanning the task alone
                                    #   (the replan row) must fail it

The task name (``name``) must be the file's stem.

**Resolution length** of a run: the number of plan actions completed after the first anomaly
until the loop ends (every round after the first anomalous one; actions of an interrupted round
count as far as they were completed). ``l_gt`` is the shortest resolution found from the true
anomaly state when the robot is told the truth there — the labelled oracle's goals (the oracle
reads the simulator's true state; it is an upper bound, never a default) — by the default greedy
planner under each ``PYTHONHASHSEED`` of :data:`HASH_SEEDS` (its tie-breaking depends on string
hashing) and by an optimal search (:data:`OPTIMAL_SEARCH`, :func:`optimal_resolution`).
``validate-data`` recomputes both and reports a mismatch; a planner time-out is reported as
such, never as "unreachable" (:data:`NO_VERDICT`).

**Effective goal sets** (``effective``): ``validate-data`` checks that each parses as an answer
would (the task's goal vocabulary) and that, proposed as the first answer at the anomaly (as the
oracle's goals are), the loop accepts it unchanged and plans it from the anomaly state (a run
that then does not resolve the task is a note, not an error). A task marked ``measures_llm``
must be failed by the ``replan`` baseline (:mod:`llmpas.experiments.replan`) and by an
irrelevant goal (:func:`irrelevant_goal`): its anomaly's cause is something the robot must be
told or infer, not a fact the planner already has.

**Judging** a run (:func:`judge`): the closed loop (:func:`llmpas.system.run`) runs the task
with the given LLM and prompting method; the sample succeeds when every goal the LLM proposed
was parsed and validated (the loop rejects the others, with repairs), the planner found plans
from the anomaly state, the loop ended reporting the task done within its budget of LLM rounds,
AND the success condition holds on the simulator's TRUE final state.
"""

from __future__ import annotations

import enum
import hashlib
import logging
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

from llmpas.errors import InputError
from llmpas.execution.anomaly import AnomalyReport
from llmpas.experiments.effective import (
    EffectiveSetError,
    as_search,
    is_effective,
    lost_object,
    parse_set,
)
from llmpas.experiments.oracles.household import oracle as household_oracle
from llmpas.experiments.replan import Replan
from llmpas.experiments.worlds import LoopConfig
from llmpas.inputs import TOML_LIMIT, decode_text, parse_toml, read_bytes
from llmpas.language.errors import PddlSyntaxError
from llmpas.language.logic import Atom, Formula, Not
from llmpas.language.problem import Problem
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.planning import PlannerConfig
from llmpas.planning.config import Algorithm
from llmpas.planning.result import PlanStatus
from llmpas.reasoning.goals import GoalParse, GoalStatus, Literal, parse_goals
from llmpas.reasoning.llm import LLM, Request, Response
from llmpas.reasoning.methods import Proposal
from llmpas.reasoning.program import parse_program
from llmpas.system import LLMFor, LoopResult, LoopSettings, close_loop, run
from llmpas.worlds.api import holds
from llmpas.worlds.household.decomposition import ExplorationConfig
from llmpas.worlds.household.layout import kitchen
from llmpas.worlds.household.plugin import WORLD, HouseholdSession, household_for
from llmpas.worlds.household.reasoning import PROGRAM_CALLS, vocabulary
from llmpas.worlds.household.scenario import Scenario, ScenarioError
from llmpas.worlds.household.sim import HouseholdWorld
from llmpas.worlds.household.state import HIDDEN, PROCESS_EFFECTS, TrueState, true_facts

log = logging.getLogger(__name__)

SUITE_DIR = Path(__file__).with_name("suite") / "household"
"""The shipped household suite (at least 20 tasks per category, :data:`MINIMUM_COUNTS`)."""


class Category(enum.Enum):
    OBJECT_LOSS = "object-loss"
    ACTION_BLOCKING = "action-blocking"
    STATE_CHANGE = "state-change"

    @property
    def title(self) -> str:
        return self.value.replace("-", " ").title()


MINIMUM_COUNTS: Mapping[Category, int] = {
    Category.OBJECT_LOSS: 20,
    Category.ACTION_BLOCKING: 20,
    Category.STATE_CHANGE: 20,
}
"""How many tasks of each category the shipped suite has at least (60 in all, 20 per category:
the paper's n = 10, 5, 5 extended so that an SR of a category is not decided by one task)."""

ANOMALY_KINDS: Mapping[Category, frozenset[tuple[str, bool]]] = {
    # (On obj region) failed: the object is not where it was believed
    Category.OBJECT_LOSS: frozenset({("on", False)}),
    # (not (Full region)): occupied; (not (Obstructed door)): something stands in front of it;
    # (not (Jammed door)): it does not open
    Category.ACTION_BLOCKING: frozenset({("full", True), ("obstructed", True), ("jammed", True)}),
    # an object state that makes a step fail: dirty, hot, spilled, wet (it would soak the
    # drawer), broken, already cooked
    Category.STATE_CHANGE: frozenset(
        {
            ("dirty", True),
            ("hot", True),
            ("spilled", True),
            ("wet", True),
            ("soaks", True),
            ("broken", True),
            ("cooked", True),
        }
    ),
}
"""The constraints a first anomaly of each category may violate: (predicate, negated). Every
anomaly kind the world models belongs to one category."""

UNMODELLED_CAUSES: Mapping[Category, frozenset[str]] = {
    Category.OBJECT_LOSS: frozenset(),
    Category.ACTION_BLOCKING: frozenset({"crowded"}),  # another object in a one-at-a-time
    Category.STATE_CHANGE: HIDDEN,  # an object state the domain does not model
}
"""Or: a process failed (the report names the skill, ``(cook)``) for a cause the domain does not
model, whose reason code (the world's log) is one of these: the cause is in the failure's text
only, never in the belief."""

JUDGE_FIELDS = ("category", "l_gt", "success", "effective", "measures_llm")
SUCCESS_PREDICATES: Mapping[str, int] = {
    "on": 2,
    "holding": 1,
    "open": 1,
    "dirty": 1,
    "cleaned": 1,
    "cooked": 1,
    "heated": 1,
    "cooled": 1,
}


class SuiteError(InputError):
    """A task file that cannot be loaded: ``file: field: message`` on one line."""


# ------------------------------------------------------------------------------------ tasks


@dataclass(frozen=True)
class SuiteTask:
    """One task of the suite: a scenario plus how to judge it."""

    name: str
    category: Category
    l_gt: int
    success: str  # PDDL formula checked on the true final state
    scenario: Scenario = field(repr=False)
    source: str = "<task>"
    digest: str = ""  # sha256 of the file's text (cache keys change when the file does)
    effective: tuple[str, ...] = ()  # goal sets an expert accepts (PDDL conjunctions)
    measures_llm: bool = False  # in the suite that measures the LLM (replan must fail it)

    def __post_init__(self) -> None:
        if self.l_gt < 1:
            raise ValueError(f"{self.source}: judge.l_gt must be >= 1, got {self.l_gt}")
        if self.name != self.scenario.name:
            raise ValueError(f"{self.source}: name {self.name!r} != {self.scenario.name!r}")
        _success_formula(self.success, self.source, _known_names(self.scenario))
        self.effective_sets()

    def effective_sets(self) -> tuple[tuple[Literal, ...], ...]:
        """The effective sets as literals (SuiteError naming the file and the set)."""
        vocab = vocabulary(household_for(self.scenario))
        out = []
        for i, text in enumerate(self.effective):
            try:
                out.append(parse_set(text, vocab))
            except EffectiveSetError as e:
                raise SuiteError(f"{self.source}: judge.effective[{i}]: {e}") from None
        return tuple(out)

    def search_places(self) -> tuple[str, ...]:
        return household_for(self.scenario).search_places()


def task_from_dict(
    data: Mapping[str, Any], *, source: str = "<task>", digest: str = ""
) -> SuiteTask:
    """Check and build a task from parsed TOML: ``[judge]`` is taken out, the rest goes to the
    scenario parser unchanged."""
    rest = {k: v for k, v in data.items() if k != "judge"}
    if "judge" not in data:
        raise SuiteError(f"{source}: judge: missing (required): category, l_gt")
    judge_table = data["judge"]
    if not isinstance(judge_table, Mapping):
        raise SuiteError(f"{source}: judge: must be a table")
    for key in judge_table:
        if key not in JUDGE_FIELDS:
            raise SuiteError(
                f"{source}: judge.{key}: unknown field; fields: {', '.join(JUDGE_FIELDS)}"
            )
    try:
        scenario = Scenario.from_dict(rest, source=source)
    except ScenarioError as e:
        raise SuiteError(str(e)) from None
    stem = Path(source).stem
    if source.endswith(".toml") and scenario.name != stem:
        raise SuiteError(f"{source}: name: {scenario.name!r} must be the file's stem {stem!r}")
    raw_category = judge_table.get("category")
    if raw_category is None:
        raise SuiteError(f"{source}: judge.category: missing (required)")
    try:
        category = Category(raw_category)
    except ValueError:
        known = ", ".join(c.value for c in Category)
        raise SuiteError(
            f"{source}: judge.category: unknown category {raw_category!r}; categories: {known}"
        ) from None
    l_gt = judge_table.get("l_gt")
    if l_gt is None:
        raise SuiteError(f"{source}: judge.l_gt: missing (required)")
    if isinstance(l_gt, bool) or not isinstance(l_gt, int) or l_gt < 1:
        raise SuiteError(f"{source}: judge.l_gt: must be an integer >= 1, got {l_gt!r}")
    success = judge_table.get("success", scenario.goal)
    if not isinstance(success, str):
        raise SuiteError(f"{source}: judge.success: must be PDDL text, got {success!r}")
    _success_formula(success, source, _known_names(scenario))
    effective = judge_table.get("effective", [])
    if not isinstance(effective, list) or not all(isinstance(e, str) for e in effective):
        raise SuiteError(
            f"{source}: judge.effective: must be an array of PDDL conjunctions, got {effective!r}"
        )
    measures_llm = judge_table.get("measures_llm", False)
    if not isinstance(measures_llm, bool):
        raise SuiteError(
            f"{source}: judge.measures_llm: must be true or false, got {measures_llm!r}"
        )
    return SuiteTask(
        scenario.name,
        category,
        l_gt,
        success.strip(),
        scenario,
        source,
        digest,
        tuple(e.strip() for e in effective),
        measures_llm,
    )


def load_task(path: str | Path) -> SuiteTask:
    """Read and check one task file (:class:`SuiteError` names the file and the field)."""
    source = str(path)
    try:
        raw = read_bytes(path, "task file", TOML_LIMIT)
    except InputError as e:
        raise SuiteError(str(e)) from None
    return parse_task(raw, source)


def parse_task(raw: bytes, source: str) -> SuiteTask:
    """Check one task file's content (read elsewhere, e.g. by a cluster's driver)."""
    try:
        data = parse_toml(decode_text(raw, source, "task file"), source)
    except InputError as e:
        raise SuiteError(str(e)) from None
    return task_from_dict(data, source=source, digest=hashlib.sha256(raw).hexdigest())


def task_files(folder: str | Path = SUITE_DIR) -> list[Path]:
    folder = Path(folder)
    if not folder.is_dir():
        raise SuiteError(f"{folder}: no such folder")
    return sorted(folder.glob("*.toml"))


def load_suite(
    folder: str | Path = SUITE_DIR, names: Iterable[str] | None = None
) -> tuple[SuiteTask, ...]:
    """Every task of ``folder`` (or only ``names``), sorted by category then name. Any broken
    file is an error (one line per file), never skipped."""
    files = task_files(folder)
    if not files:
        raise SuiteError(f"{folder}: no task files (*.toml)")
    wanted = None if names is None else set(names)
    tasks, errors = [], []
    for path in files:
        if wanted is not None and path.stem not in wanted:
            continue
        try:
            tasks.append(load_task(path))
        except SuiteError as e:
            errors.append(str(e))
    if errors:
        raise SuiteError("\n".join(errors))
    if wanted is not None:
        missing = wanted - {t.name for t in tasks}
        if missing:
            known = ", ".join(p.stem for p in files)
            raise SuiteError(
                f"{folder}: unknown task(s) {', '.join(sorted(missing))}; tasks: {known}"
            )
    order = list(Category)
    return tuple(sorted(tasks, key=lambda t: (order.index(t.category), t.name)))


# ---------------------------------------------------------------------------- the success check


def _known_names(scenario: Scenario) -> set[str]:
    layout = kitchen()
    return {*scenario.specs, *layout.regions, *layout.furniture}


def _success_formula(text: str, source: str, known: set[str]) -> SList:
    where = f"{source}: judge.success"
    try:
        exprs = parse_all(text, "judge.success")
    except PddlSyntaxError as e:
        raise SuiteError(f"{where}: malformed PDDL: {e.message}") from None
    if len(exprs) != 1 or not isinstance(exprs[0], SList):
        raise SuiteError(f"{where}: must be one parenthesised PDDL formula")
    _check_success(exprs[0], where, known)
    return exprs[0]


def _check_success(e: SList, where: str, known: set[str]) -> None:
    head = e.head()
    if head in ("and", "or"):
        for item in e.items[1:]:
            if not isinstance(item, SList):
                raise SuiteError(f"{where}: ({head} ...) takes formulas, got {item}")
            _check_success(item, where, known)
        return
    if head == "not":
        if len(e.items) != 2 or not isinstance(e.items[1], SList):
            raise SuiteError(f"{where}: (not ...) takes one formula")
        _check_success(e.items[1], where, known)
        return
    if head is None or head not in SUCCESS_PREDICATES:
        preds = ", ".join(sorted(SUCCESS_PREDICATES))
        raise SuiteError(f"{where}: unknown predicate {head!r}; predicates: and, or, not, {preds}")
    args = e.items[1:]
    if len(args) != SUCCESS_PREDICATES[head]:
        raise SuiteError(f"{where}: ({head} ...) takes {SUCCESS_PREDICATES[head]} argument(s)")
    for a in args:
        if not isinstance(a, Sym) or a.text not in known:
            raise SuiteError(
                f"{where}: unknown name {a} in ({head} ...); names: {', '.join(sorted(known))}"
            )


def holds_in_truth(formula: str, truth: TrueState) -> bool:
    """Whether the success formula holds on the simulator's true state: the one truth judge
    (:func:`llmpas.worlds.api.holds`) over the true facts, as ``llmpas run`` judges a task."""
    return holds(formula, true_facts(truth))


# ------------------------------------------------------------------------------------ judging


class Verdict(enum.Enum):
    SUCCESS = "success"  # the loop reported the task done and the truth agrees
    NOT_DONE = "not-done"  # the loop gave up (no usable goals, no plan, out of rounds)
    FALSE_DONE = "false-done"  # the loop believed the task done but the truth disagrees
    NO_ANOMALY = "no-anomaly"  # nothing went wrong: there was nothing to resolve


@dataclass(frozen=True)
class Judgement:
    """The judged outcome of one closed-loop run of one task."""

    task: str
    category: Category
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

    @property
    def success(self) -> bool:
        return self.verdict is Verdict.SUCCESS

    def to_json(self) -> dict[str, Any]:
        return {
            "task": self.task,
            "category": self.category.value,
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


def first_anomaly(result: LoopResult) -> tuple[int, AnomalyReport] | None:
    for i, rnd in enumerate(result.rounds):
        if rnd.episode is not None and rnd.episode.anomaly is not None:
            return i, rnd.episode.anomaly
    return None


def resolution_length(result: LoopResult) -> int:
    """Plan actions completed after the first anomaly (0 when there was none)."""
    first = first_anomaly(result)
    if first is None:
        return 0
    return sum(
        len(r.episode.completed) for r in result.rounds[first[0] + 1 :] if r.episode is not None
    )


def _answer_reader(task: SuiteTask, config: LoopConfig) -> Callable[[str], GoalParse]:
    """How the method reads a goal answer (to count answers that do not even parse): the
    methods module's own reader when it has one, else goals (programs for ProgPrompt)."""
    vocab = vocabulary(household_for(task.scenario))
    from llmpas.reasoning import methods

    reader = getattr(methods, "_reader", None)
    if reader is not None:
        blank = methods.Situation("", "", "", "", "", calls=PROGRAM_CALLS)
        read, _ = reader(blank, vocab, config.method)
        return cast(Callable[[str], GoalParse], read)
    if config.method.method == "progprompt":
        return lambda text: parse_program(text, PROGRAM_CALLS, vocab)
    return lambda text: parse_goals(text, vocab)


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
    first = first_anomaly(result)
    if first is None:
        verdict = Verdict.NO_ANOMALY
    elif not result.believed:  # the loop's own verdict (``success`` is the truth's)
        verdict = Verdict.NOT_DONE
    elif not holds:
        verdict = Verdict.FALSE_DONE
    else:
        verdict = Verdict.SUCCESS
    proposals = [r.proposal for r in result.rounds if r.proposal is not None]
    answers = syntax = 0
    read = _answer_reader(task, config)
    first_goals = first_answer_goals(proposals[0] if proposals else None, read)
    sets = task.effective_sets()
    lost = lost_object(first[1].constraint) if first else None
    first_effective = (  # None: nothing to judge (no sets, or no anomaly to resolve)
        is_effective(first_goals, sets, lost, task.search_places()) if sets and first else None
    )
    for p in proposals:
        for ex in p.exchanges:
            if ex.tag != "goals" and not ex.tag.startswith("repair"):
                continue
            answers += 1
            syntax += read(ex.response.text).status in (GoalStatus.SYNTAX, GoalStatus.EMPTY)
    return Judgement(
        task=task.name,
        category=task.category,
        verdict=verdict,
        completed=bool(result.believed),
        resolution_length=resolution_length(result),
        anomaly=str(first[1].constraint) if first else "",
        rounds=len(result.rounds),
        proposals=len(proposals),
        answers=answers,
        syntax_errors=syntax,
        repairs=sum(p.repairs for p in proposals),
        tokens=sum(p.tokens for p in proposals),
        latency=sum(p.latency for p in proposals),
        first_status=proposals[0].parse.status.value if proposals else "",
        goals=tuple(str(g) for p in proposals for g in p.goals),
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


# --------------------------------------------------------------------------------- validation


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
    if first_round is None or first_round.plan.plan is None:
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
    first = first_anomaly(result)
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
    return OracleRun(src, tuple(issues), resolution_length(result), seed)


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
        first = first_anomaly(result)
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
    return resolution_length(result) if first_anomaly(result) is not None else None


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


def _oracle_run_file(args: tuple[str, LoopConfig, bool]) -> OracleRun:
    """:func:`oracle_run` on a task file (module level: runs in a spawned process)."""
    path, config, judge_sets = args
    try:
        return oracle_run(load_task(path), config, judge_sets=judge_sets)
    except Exception as e:  # a crash in one task is reported, the others are still checked
        log.exception("checking %s failed", path)
        issue = Issue(path, "file", f"checking crashed: {type(e).__name__}: {e}")
        return OracleRun(path, (issue,), None)


def _runs_with_hash_seed(
    tasks: Sequence[SuiteTask],
    config: LoopConfig,
    hash_seed: int,
    jobs: int,
    progress: Callable[[str], None] | None,
    judge_sets: bool = False,
) -> list[OracleRun]:
    """Oracle runs of ``tasks`` in fresh processes with ``PYTHONHASHSEED=hash_seed``."""
    import multiprocessing
    import os
    from concurrent.futures import ProcessPoolExecutor

    before = os.environ.get("PYTHONHASHSEED")
    os.environ["PYTHONHASHSEED"] = str(hash_seed)  # read by the spawned interpreters
    try:
        context = multiprocessing.get_context("spawn")
        # one fresh process per run: a run never depends on what ran before it (counters,
        # caches), so the result is the same whatever the order and the number of jobs
        with ProcessPoolExecutor(
            max_workers=jobs, mp_context=context, max_tasks_per_child=1
        ) as pool:
            futures = [pool.submit(_oracle_run_file, (t.source, config, judge_sets)) for t in tasks]
            runs = []
            for t, f in zip(tasks, futures, strict=True):
                runs.append(f.result())
                if progress is not None:
                    progress(t.name)
    finally:
        if before is None:
            os.environ.pop("PYTHONHASHSEED", None)
        else:
            os.environ["PYTHONHASHSEED"] = before
    return runs


@dataclass(frozen=True)
class Validation:
    tasks: tuple[SuiteTask, ...]
    issues: tuple[Issue, ...]
    checked: int  # files looked at
    replan: Mapping[str, str] = field(default_factory=dict)  # task -> the replan verdict
    notes: tuple[Issue, ...] = ()  # remarks that are not errors (effective sets)

    @property
    def ok(self) -> bool:
        return not self.issues


def validate_folder(
    folder: str | Path = SUITE_DIR,
    config: LoopConfig | None = None,
    *,
    hash_seeds: Sequence[int] = HASH_SEEDS,
    jobs: int = 1,
    expect_counts: bool | None = None,
    progress: Callable[[str], None] | None = None,
) -> Validation:
    """Check every task file of ``folder``: static errors (format, unknown names), then oracle
    runs with each of ``hash_seeds`` in ``jobs`` spawned processes (see :func:`oracle_run` and
    :func:`check_task`; no hash seeds: one run in this process). ``expect_counts``: require the
    shipped suite's task counts (:data:`MINIMUM_COUNTS` per category; default: only for the
    shipped folder).
    ``progress`` is called once per file and per oracle run."""
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    config = config or LoopConfig()
    folder = Path(folder)
    issues: list[Issue] = []
    try:
        files = task_files(folder)
    except SuiteError as e:
        return Validation((), (Issue(str(folder), "folder", str(e).split(": ", 1)[-1]),), 0)
    if not files:
        return Validation((), (Issue(str(folder), "folder", "no task files (*.toml)"),), 0)
    tasks: list[SuiteTask] = []
    for path in files:
        try:
            tasks.append(load_task(path))
        except SuiteError as e:
            issues.append(issue_from(e, str(path)))
            if progress is not None:  # no oracle runs for it either
                for _ in range(max(1, len(hash_seeds))):
                    progress(path.stem)
        if progress is not None:
            progress(path.stem)
    runs: dict[str, list[OracleRun]] = {t.source: [] for t in tasks}
    if hash_seeds:  # effective sets and the replan baseline: with the first hash seed
        for k, seed in enumerate(hash_seeds):
            for r in _runs_with_hash_seed(tasks, config, seed, jobs, progress, k == 0):
                runs[r.source].append(r)
    else:
        for t in tasks:
            runs[t.source].append(_oracle_run_file((t.source, config, True)))
            if progress is not None:
                progress(t.name)
    exact = set(HASH_SEEDS) <= set(hash_seeds)
    replan: dict[str, str] = {}
    notes: list[Issue] = []
    for t in tasks:
        issues.extend(check_task(t, runs[t.source], exact=exact))
        replan[t.name] = next((r.replan for r in runs[t.source] if r.replan), "")
        notes.extend(n for r in runs[t.source] for n in r.notes if n not in notes)
    if expect_counts is None:
        expect_counts = folder.resolve() == SUITE_DIR.resolve()
    if expect_counts and len(tasks) == len(files):
        for cat, n in MINIMUM_COUNTS.items():
            have = sum(t.category is cat for t in tasks)
            if have < n:
                issues.append(
                    Issue(
                        str(folder),
                        "judge.category",
                        f"{have} {cat.value} tasks, expected at least {n}",
                    )
                )
    return Validation(tuple(tasks), tuple(issues), len(files), replan, tuple(notes))


__all__ = [
    "ANOMALY_KINDS",
    "HASH_SEEDS",
    "MINIMUM_COUNTS",
    "NO_VERDICT",
    "OPTIMAL_SEARCH",
    "SUITE_DIR",
    "UNMODELLED_CAUSES",
    "Category",
    "Issue",
    "Judgement",
    "OptimalSession",
    "OracleRun",
    "SuiteError",
    "SuiteTask",
    "Validation",
    "Verdict",
    "anomaly_category",
    "check_task",
    "holds_in_truth",
    "irrelevant_goal",
    "irrelevant_issues",
    "judge",
    "load_suite",
    "load_task",
    "optimal_resolution",
    "oracle_run",
    "planner_limit",
    "resolution_length",
    "run_traced",
    "task_from_dict",
    "validate_folder",
]
