"""The suite's task format: one TOML file per task, a household scenario plus a ``[judge]``
table (see the package's documentation and ``household/README.md``), read and checked here, its
fields with the readers the scenario parser uses (:class:`llmpas.fields.Fields`)."""

from __future__ import annotations

import enum
import hashlib
import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from llmpas.errors import InputError
from llmpas.experiments.effective import (
    EffectiveSetError,
    parse_set,
)
from llmpas.fields import Fields
from llmpas.inputs import TOML_LIMIT, decode_text, parse_toml, read_bytes
from llmpas.language.language_errors import PddlSyntaxError
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.reasoning.goal_reading import Literal
from llmpas.worlds.household.household_plugin import household_for
from llmpas.worlds.household.household_reasoning import vocabulary
from llmpas.worlds.household.layout import kitchen
from llmpas.worlds.household.scenario import Scenario, ScenarioError
from llmpas.worlds.household.state import HIDDEN

log = logging.getLogger(__name__)

SUITE_DIR = Path(__file__).with_name("household")
"""The shipped household suite (at least 20 tasks per category, :data:`MINIMUM_COUNTS`)."""

SUITE_B_DIR = Path(__file__).with_name("household-b")
"""The second household suite (issue #36): 42 tasks written after the first suite's methods, in
other words; to be frozen by a commit of its own before any model runs on it (``--suite`` of
``bench prompting``)."""

SUITE_B_DIGEST = "2141531e88cf8c9a842f95ab1646a6a10ab1b03466e04e3944f01ca62bfbe973"
""":func:`suite_digest` of :data:`SUITE_B_DIR` as frozen (a test checks it), after ``llmpas bench
validate-data`` passed on it (docs/results/household-b-validate.md) and before any model ran on
it; a change needs a new suite and a new digest, never an edit."""


HALVES = ("development", "rest")


def development_half(tasks: Iterable[SuiteTask]) -> frozenset[str]:
    """The names of the development half of ``tasks``: per category, the first half (rounded
    up) in the order of the SHA-256 of their names: a fixed split by name alone, the same for
    any method and run, on which a choice (a scoring) is made before the whole suite runs."""
    out: set[str] = set()
    for cat in Category:
        names = sorted(
            (t.name for t in tasks if t.category is cat),
            key=lambda n: hashlib.sha256(n.encode("utf-8")).hexdigest(),
        )
        out |= set(names[: (len(names) + 1) // 2])
    return frozenset(out)


def suite_digest(folder: Path) -> str:
    """SHA-256 over a folder's task files (their names and bytes, in name order)."""
    h = hashlib.sha256()
    for path in sorted(folder.glob("*.toml")):
        h.update(path.name.encode("utf-8") + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


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
    fields = Fields(source, SuiteError)  # the scenario parser's readers
    judge_table = fields.table(data["judge"], "judge", JUDGE_FIELDS)
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
    effective = [
        fields.string(e, f"judge.effective[{i}]")
        for i, e in enumerate(fields.array(judge_table.get("effective", []), "judge.effective"))
    ]
    measures_llm = fields.boolean(judge_table.get("measures_llm", False), "judge.measures_llm")
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
