"""Judged household tasks: a household scenario file with a ``[judge]`` table (its anomaly's
category, the shortest resolution ``l_gt``, the ``success`` condition on the true final state,
the goal sets an expert accepts and whether it measures the LLM), read and checked here with the
readers the scenario parser uses (:class:`llmpas.fields.Fields`).

``llmpas run TASK.toml`` runs such a file as ``llmpas bench prompting`` runs it (its scenario,
ended by its ``success`` intent: :func:`judged`); the suite of them and the judge of a run are the
lab's (:mod:`llmpas.experiments.suite`). Errors are :class:`TaskFileError`, one line naming the
file and the field."""

from __future__ import annotations

import enum
import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from llmpas.errors import InputError
from llmpas.fields import Fields
from llmpas.inputs import TOML_LIMIT, decode_text, parse_toml, read_bytes
from llmpas.language.language_errors import PddlSyntaxError
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.worlds.household.household_plugin import household_for
from llmpas.worlds.household.layout import kitchen
from llmpas.worlds.household.scenario import Scenario, ScenarioError


class Category(enum.Enum):
    OBJECT_LOSS = "object-loss"
    ACTION_BLOCKING = "action-blocking"
    STATE_CHANGE = "state-change"

    @property
    def title(self) -> str:
        return self.value.replace("-", " ").title()


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


class TaskFileError(InputError):
    """A task file that cannot be loaded: ``file: field: message`` on one line."""


@dataclass(frozen=True)
class HouseholdTask:
    """A judged task: a household scenario plus how to judge a run of it (the ``[judge]``
    table; its effective goal sets are kept as text: the suite reads them)."""

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

    def search_places(self) -> tuple[str, ...]:
        return household_for(self.scenario).search_places()


def task_from_dict(
    data: Mapping[str, Any], *, source: str = "<task>", digest: str = ""
) -> HouseholdTask:
    """Check and build a task from parsed TOML: ``[judge]`` is taken out, the rest goes to the
    scenario parser unchanged."""
    rest = {k: v for k, v in data.items() if k != "judge"}
    if "judge" not in data:
        raise TaskFileError(f"{source}: judge: missing (required): category, l_gt")
    fields = Fields(source, TaskFileError)  # the scenario parser's readers
    judge_table = fields.table(data["judge"], "judge", JUDGE_FIELDS)
    try:
        scenario = Scenario.from_dict(rest, source=source)
    except ScenarioError as e:
        raise TaskFileError(str(e)) from None
    stem = Path(source).stem
    if source.endswith(".toml") and scenario.name != stem:
        raise TaskFileError(f"{source}: name: {scenario.name!r} must be the file's stem {stem!r}")
    raw_category = judge_table.get("category")
    if raw_category is None:
        raise TaskFileError(f"{source}: judge.category: missing (required)")
    try:
        category = Category(raw_category)
    except ValueError:
        known = ", ".join(c.value for c in Category)
        raise TaskFileError(
            f"{source}: judge.category: unknown category {raw_category!r}; categories: {known}"
        ) from None
    l_gt = judge_table.get("l_gt")
    if l_gt is None:
        raise TaskFileError(f"{source}: judge.l_gt: missing (required)")
    if isinstance(l_gt, bool) or not isinstance(l_gt, int) or l_gt < 1:
        raise TaskFileError(f"{source}: judge.l_gt: must be an integer >= 1, got {l_gt!r}")
    success = judge_table.get("success", scenario.goal)
    if not isinstance(success, str):
        raise TaskFileError(f"{source}: judge.success: must be PDDL text, got {success!r}")
    _success_formula(success, source, _known_names(scenario))
    effective = [
        fields.string(e, f"judge.effective[{i}]")
        for i, e in enumerate(fields.array(judge_table.get("effective", []), "judge.effective"))
    ]
    measures_llm = fields.boolean(judge_table.get("measures_llm", False), "judge.measures_llm")
    return HouseholdTask(
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


def load_task(path: str | Path) -> HouseholdTask:
    """Read and check one task file (:class:`TaskFileError` names the file and the field)."""
    source = str(path)
    try:
        raw = read_bytes(path, "task file", TOML_LIMIT)
    except InputError as e:
        raise TaskFileError(str(e)) from None
    return parse_task(raw, source)


def parse_task(raw: bytes, source: str) -> HouseholdTask:
    """Check one task file's content (read elsewhere, e.g. by a cluster's driver)."""
    try:
        data = parse_toml(decode_text(raw, source, "task file"), source)
    except InputError as e:
        raise TaskFileError(str(e)) from None
    return task_from_dict(data, source=source, digest=hashlib.sha256(raw).hexdigest())


def judged(path: str | Path) -> tuple[Scenario, str] | None:
    """A ``.toml`` file with a ``[judge]`` table: its scenario and its ``success`` intent (the
    registry's hook for ``llmpas run``); None for any other file (a plain scenario file, whose
    errors the scenario reader reports). The file is read once, bounded."""
    source = str(path)
    try:  # regular files only (a FIFO or a device is the scenario reader's to name)
        raw = read_bytes(path, "scenario", TOML_LIMIT)
        data = parse_toml(decode_text(raw, source, "scenario"), source)
    except InputError:
        return None
    if "judge" not in data:
        return None
    task = task_from_dict(data, source=source, digest=hashlib.sha256(raw).hexdigest())
    return task.scenario, task.success


# ---------------------------------------------------------------------------- the success check


def _known_names(scenario: Scenario) -> set[str]:
    layout = kitchen()
    return {*scenario.specs, *layout.regions, *layout.furniture}


def _success_formula(text: str, source: str, known: set[str]) -> SList:
    where = f"{source}: judge.success"
    try:
        exprs = parse_all(text, "judge.success")
    except PddlSyntaxError as e:
        raise TaskFileError(f"{where}: malformed PDDL: {e.message}") from None
    if len(exprs) != 1 or not isinstance(exprs[0], SList):
        raise TaskFileError(f"{where}: must be one parenthesised PDDL formula")
    _check_success(exprs[0], where, known)
    return exprs[0]


def _check_success(e: SList, where: str, known: set[str]) -> None:
    head = e.head()
    if head in ("and", "or"):
        for item in e.items[1:]:
            if not isinstance(item, SList):
                raise TaskFileError(f"{where}: ({head} ...) takes formulas, got {item}")
            _check_success(item, where, known)
        return
    if head == "not":
        if len(e.items) != 2 or not isinstance(e.items[1], SList):
            raise TaskFileError(f"{where}: (not ...) takes one formula")
        _check_success(e.items[1], where, known)
        return
    if head is None or head not in SUCCESS_PREDICATES:
        preds = ", ".join(sorted(SUCCESS_PREDICATES))
        raise TaskFileError(
            f"{where}: unknown predicate {head!r}; predicates: and, or, not, {preds}"
        )
    args = e.items[1:]
    if len(args) != SUCCESS_PREDICATES[head]:
        raise TaskFileError(f"{where}: ({head} ...) takes {SUCCESS_PREDICATES[head]} argument(s)")
    for a in args:
        if not isinstance(a, Sym) or a.text not in known:
            raise TaskFileError(
                f"{where}: unknown name {a} in ({head} ...); names: {', '.join(sorted(known))}"
            )
