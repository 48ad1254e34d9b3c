"""The suite's tasks: folders of judged household task files (the format is the household
world's, :mod:`llmpas.worlds.household.household_tasks`), their effective goal sets read as
answers, the suites' halves and digests."""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from llmpas.experiments.effective import (
    EffectiveSetError,
    parse_set,
)
from llmpas.reasoning.goal_reading import Literal
from llmpas.worlds.household import household_tasks
from llmpas.worlds.household.household_plugin import household_for
from llmpas.worlds.household.household_reasoning import vocabulary
from llmpas.worlds.household.household_tasks import (
    Category,
    HouseholdTask,
    TaskFileError,
)
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

# ------------------------------------------------------------------------------------ tasks


SuiteError = TaskFileError
"""A task file (or a suite folder) that cannot be loaded: one line per file."""


@dataclass(frozen=True)
class SuiteTask(HouseholdTask):
    """One task of the suite: a judged household task whose effective goal sets parse as
    answers would (the task's goal vocabulary)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self.effective_sets()

    @classmethod
    def of(cls, task: HouseholdTask) -> SuiteTask:
        return cls(**{f.name: getattr(task, f.name) for f in fields(task)})

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


def task_from_dict(
    data: Mapping[str, Any], *, source: str = "<task>", digest: str = ""
) -> SuiteTask:
    """Check and build a task from parsed TOML (:func:`household_tasks.task_from_dict`, and its
    effective sets)."""
    return SuiteTask.of(household_tasks.task_from_dict(data, source=source, digest=digest))


def load_task(path: str | Path) -> SuiteTask:
    """Read and check one task file (:class:`SuiteError` names the file and the field)."""
    return SuiteTask.of(household_tasks.load_task(path))


def parse_task(raw: bytes, source: str) -> SuiteTask:
    """Check one task file's content (read elsewhere, e.g. by a cluster's driver)."""
    return SuiteTask.of(household_tasks.parse_task(raw, source))


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
