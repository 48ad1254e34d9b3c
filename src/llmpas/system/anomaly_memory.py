"""The anomaly being resolved and the memory of what was tried for it.

The executor's :class:`~llmpas.execution.anomaly_report.AnomalyReport` is read here and nowhere
else in
the loop: :class:`Anomaly` is what the other rooms ask of it (its sentence, its key, the failed
step, the objects it names, where a failed detection looked, whether a plan repeats its step).
:func:`unknown_place` makes one when the task cannot be planned because it names a lost object.
:class:`Tried` remembers the goals that were achieved in vain and those whose execution failed,
and writes the prompt's history of them.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.plan_builder import planned_action
from llmpas.language.logic import Atom, Formula, Not, atoms_of
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics
from llmpas.planning import Plan
from llmpas.system.recovery import conjuncts

_WORD = re.compile(r"[a-z][a-z0-9_-]*")


@dataclass(frozen=True)
class Anomaly:
    """One anomaly, as the loop reads it."""

    report: AnomalyReport

    @property
    def text(self) -> str:
        """The sentence the prompt shows."""
        return self.report.describe()

    @property
    def constraint(self) -> Formula:
        return self.report.constraint

    @property
    def key(self) -> str:
        """The same anomaly again has the same key (a ranking made for it is reused)."""
        r = self.report
        return "|".join((r.action, *r.args, str(r.constraint), r.reason))

    @property
    def step(self) -> str:
        """The failed step, ``action arg...``."""
        return " ".join((self.report.action, *self.report.args))

    @property
    def reason(self) -> str:
        return self.report.reason

    @property
    def failure(self) -> str:
        """Why a round whose goals were pursued failed, in the prompt's history."""
        return f"{self.report.action} failed ({self.report.reason})"

    def objects(self, known: Iterable[str]) -> set[str]:
        """The objects of ``known`` the anomaly names: the failed step's arguments, the failed
        literal's and those its reason mentions."""
        r = self.report
        names = set(r.args)
        c = r.constraint
        atom = c.arg if isinstance(c, Not) else c
        names |= set(getattr(atom, "args", ()))
        names |= set(_WORD.findall(r.reason.lower()))
        return names & set(known)

    def detected(self, detection: str) -> str | None:
        """The object a failed detection looked for (None: not a failed ``detection``)."""
        r = self.report
        if r.constraint_name != detection:
            return None
        return str(r.constraint.args[0]) if isinstance(r.constraint, Atom) else ""

    def repeated_by(self, sem: Semantics, plan: Plan | None, problem: Problem) -> bool:
        """Whether ``plan`` repeats the failed step with nothing believed explaining it."""
        return plan is not None and repeats_failure(sem, self.report, plan, problem)


def unknown_place(
    task: Formula,
    lost: Callable[[str], bool],
    location: str,
    detection: str,
    belief: Iterable[Atom],
) -> Anomaly | None:
    """The task cannot be planned and names an object the robot knows of but cannot place:
    an anomaly (a failed detection of it, with nothing looked at yet), so that the LLM is
    asked where to search instead of the loop ending with no plan."""
    missing = sorted({o for a in atoms_of(task) for o in a.args if lost(o)})
    if not missing:
        return None
    obj = missing[0]
    report = AnomalyReport(
        action="plan",
        args=(obj,),
        steps=(),
        subtree="plan",
        sub_action="locate",
        constraint=Atom(location, (obj, "?")),
        constraint_name=detection,
        reason=f"where {obj} is, is unknown: the task cannot be planned before it is found",
        explored={},
        attempts=0,
        failures={},
        observations=(),
        belief=tuple(sorted(belief)),
    )
    return Anomaly(report)


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


@dataclass
class Tried:
    """The LLM's goals tried for the anomalies of one run: ``tried``, achieved and did not
    help; ``failed``, their execution failed (and why); ``failed_since``, failed with nothing
    done since (proposed again they are rejected; once a round has carried out a step the state
    has changed and they may be proposed again: the mug taken out of the sink, rinsing the
    apple there can succeed); ``just_failed``, the literals of the goal whose round just failed;
    ``pending``, the goals being pursued."""

    tried: list[frozenset[str]] = field(default_factory=list)
    failed: list[tuple[frozenset[str], str]] = field(default_factory=list)
    failed_since: set[frozenset[str]] = field(default_factory=set)
    just_failed: frozenset[str] = frozenset()
    pending: frozenset[str] | None = None

    def rejected(self) -> list[frozenset[str]]:
        """The goal sets a check rejects when proposed again."""
        return [*self.tried, *self.failed_since]

    def in_vain(self) -> None:
        """The goals pursued were achieved; the task failing again, they did not help."""
        if self.pending is not None:
            self.tried.append(self.pending)

    def history(self, searches: list[str]) -> str:
        """What the prompt says was tried: the searches, the goals that did not help, then the
        goals whose execution failed (and why)."""
        lines = list(searches)
        lines += [f"- goals {' '.join(sorted(t))} did not help" for t in self.tried]
        lines += [
            f"- goals {' '.join(sorted(t))} could not be achieved: {why}" for t, why in self.failed
        ]
        return "\n".join(lines)

    def failed_round(self, anomaly: Anomaly, task: Formula, on_task: bool, acted: bool) -> None:
        """A round's execution failed: its goal is the one that just failed (an answer that
        restates it gets that feedback), and the LLM's goals it pursued count as tried, so that
        the next consultation is told so and cannot propose them again until a
        round carries out a step (``acted``: the state they failed in has changed)."""
        if acted:
            self.failed_since.clear()
        if on_task:
            self.just_failed = frozenset(str(a) for a in conjuncts(task))
            return
        if self.pending is None:
            return
        self.just_failed = self.pending
        self.failed_since.add(self.pending)
        if all(self.pending != goals for goals, _ in self.failed):
            self.failed.append((self.pending, anomaly.failure))


__all__ = [
    "Anomaly",
    "Tried",
    "believed",
    "repeats_failure",
    "same_objects",
    "unknown_place",
]
