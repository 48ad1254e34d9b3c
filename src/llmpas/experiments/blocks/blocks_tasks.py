"""Blocks-world tasks: generated (seeded) or read from a folder of PDDL problem files; their
descriptions for prompts; and the Fast Downward reference plan (optimal A* with LM-cut).

A :class:`Task` carries its problem (and, for files written for another blocks domain, that
domain) as PDDL text so it can cross process boundaries and be hashed into cache keys;
:meth:`Task.problem` parses it against its domain (the shipped one unless given). Any
four-operator blocks domain works, whatever its names (``on-table``, ``arm-empty``, ...):
:mod:`.roles` reads them from the actions.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from llmpas import inputs
from llmpas.errors import InputError
from llmpas.examples._files import read_text
from llmpas.examples.blocksworld import PACKAGE, problem_text
from llmpas.experiments.blocks.plans import Step, simulate
from llmpas.experiments.blocks.roles import (
    SHIPPED_ROLES,
    BlocksRoles,
    RolesError,
    detect_roles,
    goal_words,
)
from llmpas.language.domain import Domain, parse_domain
from llmpas.language.logic import Atom, Not, conjuncts
from llmpas.language.problem import Problem, parse_problem_text
from llmpas.language.streams import EMPTY_STREAMS
from llmpas.planning.downward import ClassicalStatus, DownwardConfig, FastDownward

log = logging.getLogger(__name__)

OPTIMAL_SEARCH = "astar(lmcut())"


class TaskError(InputError):
    """A problem file that cannot be used: one line naming the file."""


@cache
def domain_text() -> str:
    return read_text(PACKAGE, "domain.pddl")


@cache
def domain() -> Domain:
    return parse_domain(domain_text(), "blocksworld/domain.pddl")


@dataclass(frozen=True)
class Task:
    """One blocks-world problem: ``name`` is unique within a run, ``size`` the number of blocks,
    ``source`` where it came from (``generated`` or the file), ``text`` its PDDL."""

    name: str
    size: int
    source: str
    text: str
    seed: int | None = None
    domain_text: str = ""  # the domain's PDDL; empty: the shipped blocks domain
    domain_source: str = ""

    def __post_init__(self) -> None:
        if not self.name.strip():
            raise ValueError("a task needs a name")
        if self.size < 1:
            raise ValueError(f"a task needs at least one block, got {self.size}")

    @property
    def domain_pddl(self) -> str:
        return self.domain_text or domain_text()

    def problem(self) -> Problem:
        return _problem(self.text, self.source, self.domain_text, self.domain_source)


@cache
def _domain(text: str, source: str) -> Domain:
    if not text:
        return domain()
    dom = parse_domain(text, source or "domain.pddl")
    detect_roles(dom)  # RolesError (a ValueError) when it is not a blocks world
    return dom


@cache
def _problem(text: str, source: str, dom_text: str = "", dom_source: str = "") -> Problem:
    dom = _domain(dom_text, dom_source)
    pf = parse_problem_text(text, dom, source)
    objects = dict(pf.objects)
    return Problem(
        dom,
        EMPTY_STREAMS,
        {o: o for o in objects},
        frozenset(pf.init),
        pf.goal,
        costs=pf.costs,
        object_types=objects,
        name=pf.name,
    )


def generated_tasks(sizes: Sequence[int], count: int, seed: int = 0) -> list[Task]:
    """``count`` instances of each size from :func:`~llmpas.examples.blocksworld.generate`,
    seeds ``seed .. seed + count - 1``."""
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    return [
        Task(f"bw{n}-s{s}", n, "generated", problem_text(n, s), s)
        for n in sizes
        for s in range(seed, seed + count)
    ]


def read_domain_file(path: str | Path) -> tuple[str, str]:
    """``(text, source)`` of a four-operator blocks domain file, checked; :class:`TaskError`
    naming the file when it cannot be read or is not such a domain."""
    path = Path(path)
    try:
        text = inputs.read_text(path, "PDDL domain file", inputs.PDDL_LIMIT)
        _domain(text, str(path))
    except (InputError, RolesError, OSError) as err:
        raise TaskError(_located(err, path)) from None
    return text, str(path)


def _located(err: Exception, path: Path) -> str:
    message = " ".join(str(err).split())
    return message if message.startswith(str(path)) else f"{path}: {message}"


def read_tasks(folder: str | Path, domain_file: str | Path | None = None) -> list[Task]:
    """Every ``*.pddl`` problem file in ``folder`` (sorted; domain files skipped), checked
    against ``domain_file`` (default: the shipped blocks-world domain). Raises
    :class:`TaskError` naming the first bad file."""
    folder = Path(folder)
    dom_text, dom_source = read_domain_file(domain_file) if domain_file else ("", "")
    if not folder.is_dir():
        raise TaskError(f"{folder}: not a folder of PDDL problem files")
    skip = {"domain.pddl"} | ({Path(domain_file).name} if domain_file else set())
    files = sorted(p for p in folder.glob("*.pddl") if p.name not in skip)
    if not files:
        raise TaskError(f"{folder}: no *.pddl problem files")
    tasks = []
    for path in files:
        try:
            text = inputs.read_text(path, "PDDL problem file", inputs.PDDL_LIMIT)
            task = Task(path.stem, 1, str(path), text, None, dom_text, dom_source)
            problem = task.problem()
        except (InputError, OSError) as err:
            raise TaskError(_located(err, path)) from None
        if not problem.objects:
            raise TaskError(f"{path}: the problem has no blocks (:objects is empty)")
        tasks.append(
            Task(path.stem, len(problem.objects), str(path), text, None, dom_text, dom_source)
        )
    return tasks


# ---------------------------------------------------------------------------- descriptions


def actions_text(dom: Domain) -> str:
    """The action library: preconditions and effects of every action, one line each."""
    lines = []
    for a in dom.actions:
        head = "(" + " ".join([a.name, *(p.name for p in a.params)]) + ")"
        pre = " ".join(map(str, conjuncts(a.precondition)))
        adds = " ".join(str(e) for e in a.effects if isinstance(e, Atom))
        dels = " ".join(str(e.arg) for e in a.effects if isinstance(e, Not))
        lines.append(f"{head}: needs {pre}; adds {adds}; deletes {dels}")
    return "\n".join(lines)


def facts_text(facts: Iterable[Atom]) -> str:
    return " ".join(sorted(map(str, facts)))


def towers(facts: Iterable[Atom], roles: BlocksRoles = SHIPPED_ROLES) -> list[list[str]]:
    """Towers listed bottom to top, from ``ontable``/``on`` facts (empty if there are none)."""
    facts = list(facts)
    above = {a.args[1]: a.args[0] for a in facts if a.predicate == roles.on and len(a.args) == 2}
    out = []
    for base in sorted(a.args[0] for a in facts if a.predicate == roles.ontable and a.args):
        tower, seen = [base], {base}
        while tower[-1] in above and above[tower[-1]] not in seen:
            tower.append(above[tower[-1]])
            seen.add(tower[-1])
        out.append(tower)
    return out


def state_words(facts: Iterable[Atom], roles: BlocksRoles = SHIPPED_ROLES) -> str:
    """The state in plain words: towers bottom to top, and the hand."""
    facts = list(facts)
    parts = [
        "tower " + ", ".join(t) + (" (bottom to top)" if len(t) > 1 else " (alone on the table)")
        for t in towers(facts, roles)
    ]
    held = [a.args[0] for a in facts if a.predicate == roles.holding and a.args]
    hand = f"the hand holds {held[0]}" if held else "the hand is empty"
    return "; ".join([*parts, hand])


def task_words(problem: Problem) -> str:
    """The task as a person would say it (what FLP's first look sees, and nothing else)."""
    roles = detect_roles(problem.domain)
    goal = "; ".join(goal_words(g, roles) for g in conjuncts(problem.goal))
    return (
        f"There are {len(problem.objects)} blocks ({', '.join(sorted(problem.objects))}). "
        f"Now: {state_words(problem.init, roles)}. "
        f"Rearrange them so that: {goal}."
    )


def problem_holds(problem: Problem) -> bool:
    """Whether the goal holds in the initial state (the empty plan solves the task)."""
    return simulate(problem, ()).success


def goal_text(problem: Problem) -> str:
    return " ".join(map(str, conjuncts(problem.goal)))


# -------------------------------------------------------------------------- reference plan


@dataclass(frozen=True)
class Reference:
    """Fast Downward's optimal plan for a task (``steps`` empty unless solved)."""

    status: ClassicalStatus
    steps: tuple[Step, ...]
    message: str = ""

    def __post_init__(self) -> None:
        if self.steps and self.status is not ClassicalStatus.SOLVED:
            raise ValueError("only a solved reference has steps")

    @property
    def length(self) -> int | None:
        return len(self.steps) if self.status is ClassicalStatus.SOLVED else None


def reference_plan(task: Task, max_time: float = 60.0) -> Reference:
    """An optimal plan (A* with LM-cut) for ``task``."""
    planner = FastDownward(DownwardConfig(search=OPTIMAL_SEARCH, max_time=max_time))
    if problem_holds(task.problem()):
        return Reference(ClassicalStatus.SOLVED, ())  # the goal holds already: the empty plan
    result = planner.solve(task.domain_pddl, task.text)
    if not result.solved:
        log.warning("%s: Fast Downward %s: %s", task.name, result.status.value, result.message)
        return Reference(result.status, (), result.message)
    return Reference(result.status, tuple(Step(n, args) for n, args in result.actions))


__all__ = [
    "Reference",
    "Task",
    "TaskError",
    "actions_text",
    "domain",
    "facts_text",
    "generated_tasks",
    "goal_text",
    "problem_holds",
    "read_domain_file",
    "read_tasks",
    "reference_plan",
    "state_words",
    "task_words",
]
