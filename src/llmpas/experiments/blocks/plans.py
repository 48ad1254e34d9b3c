"""Plans written by an LLM, read as data and judged by simulating the domain.

:func:`parse_plan` reads ``(action arg ...)`` steps out of an answer that may wrap them in
numbering, bullets, code fences or prose; an unknown action, object or a wrong number of
arguments is a syntax error naming the step. :func:`simulate` executes the steps with
:class:`~llmpas.language.semantics.Semantics` (an independent reading of PDDL, not Fast
Downward), reports the first inapplicable step with the precondition that is false, and checks
the goal at the end. :func:`plan_gbnf` is a llama.cpp grammar admitting only well-formed plans.
Nothing an LLM writes is ever executed.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from llmpas.language.domain import Action, Domain
from llmpas.language.logic import Substitution, conjuncts
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics


@dataclass(frozen=True)
class Step:
    """One ground action of a plan."""

    action: str
    args: tuple[str, ...]

    def __post_init__(self) -> None:
        if not self.action:
            raise ValueError("a plan step needs an action name")

    def __str__(self) -> str:
        return "(" + " ".join((self.action, *self.args)) + ")"


class ParseStatus(enum.Enum):
    OK = "ok"
    NO_PLAN = "no_plan"  # no step found at all
    SYNTAX_ERROR = "syntax_error"  # a step names an unknown action/object or has a wrong arity


@dataclass(frozen=True)
class PlanParse:
    status: ParseStatus
    steps: tuple[Step, ...]
    errors: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if (self.status is ParseStatus.OK) == bool(self.errors):
            raise ValueError("errors must be given exactly when the parse is not OK")

    @property
    def ok(self) -> bool:
        return self.status is ParseStatus.OK


_FENCE = re.compile(r"^\s*```[A-Za-z]*\s*$")
_MARKER = re.compile(r"^[ \t>*#]*plan[ \t*]*:", re.IGNORECASE | re.MULTILINE)
_PREFIX = re.compile(
    r"^\s*(?:(?:[-*•>]|(?:step\s*)?\d+\s*[.):]|step\s*\d+\s*[-–:]?)\s*)*", re.IGNORECASE
)
_GROUP = re.compile(r"\(([^()]*)\)")


def parse_plan(text: str, domain: Domain, objects: Iterable[str]) -> PlanParse:
    """The steps of an answer; every error names its line.

    Steps are ``(action arg ...)`` groups. When the answer has a ``Plan:`` line only what follows
    the last one is read. A group at the start of a line (after numbering or bullets) must be a
    step; a group inside prose counts only when its head is an action (so ``(clear b2)`` in an
    explanation is not a step, but ``Move it: (unstack b1 b2)`` is).
    """
    known = set(objects)
    actions = {a.name: a for a in domain.actions}
    body = text
    markers = list(_MARKER.finditer(text))
    offset = 0
    if markers:
        body = text[markers[-1].end() :]
        offset = text[: markers[-1].end()].count("\n")
    steps: list[Step] = []
    errors: list[str] = []
    for number, raw in enumerate(body.splitlines(), 1 + offset):
        if _FENCE.match(raw):
            continue
        line = _PREFIX.sub("", raw, count=1).strip().lower()
        if not line:
            continue
        starts = line.startswith("(")
        in_sequence, end = starts, 0  # a line of steps, until prose interrupts it
        for match in _GROUP.finditer(line):
            if line[end : match.start()].strip(" ,;\t"):
                in_sequence = False
            end = match.end()
            words = match.group(1).replace(",", " ").split()
            if not words:
                if in_sequence:
                    errors.append(f"line {number}: empty step '()'")
                continue
            if words[0] not in actions and not in_sequence:
                continue  # a predicate or an aside inside prose
            steps.append(Step(words[0], tuple(words[1:])))
            error = _check(steps[-1], actions, known)
            if error:
                errors.append(f"line {number}: {error}")
        if starts and line.count("(") != line.count(")"):
            errors.append(f"line {number}: unbalanced parentheses in {raw.strip()!r}")
    if errors:
        return PlanParse(ParseStatus.SYNTAX_ERROR, tuple(steps), tuple(errors))
    if not steps:
        return PlanParse(
            ParseStatus.NO_PLAN, (), ("no plan steps found: write one (action block ...) a line",)
        )
    return PlanParse(ParseStatus.OK, tuple(steps))


def _check(step: Step, actions: dict[str, Action], objects: set[str]) -> str:
    action = actions.get(step.action)
    if action is None:
        return f"unknown action {step.action!r} in {step} (actions: {', '.join(sorted(actions))})"
    if len(step.args) != len(action.params):
        params = " ".join(p.name for p in action.params)
        return (
            f"{step}: {action.name} takes {len(action.params)} argument(s) ({params}), "
            f"got {len(step.args)}"
        )
    unknown = [a for a in step.args if a not in objects]
    if unknown:
        return f"unknown object {unknown[0]!r} in {step} (objects: {' '.join(sorted(objects))})"
    return ""


# ----------------------------------------------------------------------------- simulation


class Outcome(enum.Enum):
    SUCCESS = "success"
    INAPPLICABLE = "inapplicable"  # a step's precondition is false when it is executed
    GOAL_NOT_REACHED = "goal_not_reached"  # every step ran, the goal does not hold
    SYNTAX_ERROR = "syntax_error"
    NO_PLAN = "no_plan"
    NO_REFERENCE = "no_reference"  # the oracle had no plan to give: the optimal search failed


@dataclass(frozen=True)
class Verdict:
    """What executing a plan in the simulated domain did."""

    outcome: Outcome
    message: str
    executed: int  # steps that ran before the failure (all of them on success)
    failed_step: int | None = None  # 1-based, for INAPPLICABLE

    def __post_init__(self) -> None:
        if (self.outcome is Outcome.INAPPLICABLE) != (self.failed_step is not None):
            raise ValueError("failed_step is given exactly for an inapplicable step")

    @property
    def success(self) -> bool:
        return self.outcome is Outcome.SUCCESS


def simulate(problem: Problem, steps: Sequence[Step]) -> Verdict:
    """Execute ``steps`` from ``problem.init``: the first false precondition stops the run, and
    the goal is checked after the last step."""
    sem = Semantics(problem.domain, problem.object_types, problem.costs)
    facts = set(problem.init)
    for i, step in enumerate(steps, 1):
        action = problem.domain.action(step.action)
        if len(step.args) != len(action.params):
            raise ValueError(f"{step}: wrong number of arguments (parse the plan first)")
        sub = Substitution({p.name: a for p, a in zip(action.params, step.args, strict=True)})
        state = sem.state(facts)
        for condition in conjuncts(action.precondition):
            ground = sub.formula(condition)
            if not sem.holds(ground, state):
                message = f"step {i} {step}: precondition {ground} is false"
                return Verdict(Outcome.INAPPLICABLE, message, i - 1, i)
        facts, _ = sem.apply(action, step.args, state)
    unmet = [str(g) for g in conjuncts(problem.goal) if not sem.holds(g, facts)]
    if unmet:
        message = f"after {_steps(len(steps))} the goal is not reached: " + ", ".join(
            f"{g} is false" for g in unmet
        )
        return Verdict(Outcome.GOAL_NOT_REACHED, message, len(steps))
    return Verdict(Outcome.SUCCESS, f"the goal holds after {_steps(len(steps))}", len(steps))


def _steps(n: int) -> str:
    return f"{n} step" if n == 1 else f"{n} steps"


def judge(problem: Problem, parse: PlanParse) -> Verdict:
    """The verdict on a parsed answer: syntax errors are failures before anything runs."""
    if parse.status is ParseStatus.SYNTAX_ERROR:
        return Verdict(Outcome.SYNTAX_ERROR, "; ".join(parse.errors), 0)
    if parse.status is ParseStatus.NO_PLAN:
        empty = simulate(problem, ())
        if empty.success:  # the goal holds already: no steps is the right answer
            return empty
        return Verdict(Outcome.NO_PLAN, "; ".join(parse.errors), 0)
    return simulate(problem, parse.steps)


# -------------------------------------------------------------------------------- grammar


def plan_gbnf(domain: Domain, objects: Iterable[str], max_steps: int) -> str:
    """A GBNF grammar (root rule ``root``) admitting 1..max_steps lines ``(action arg ...)``
    over the domain's actions and the given objects, each argument one of the objects.

    Only classic GBNF is used; the bound is a chain of optional rules ``m<i>``."""
    if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
        raise ValueError(f"max_steps must be a positive integer, got {max_steps!r}")
    names = sorted(set(objects))
    if not names:
        raise ValueError("a plan grammar needs at least one object")
    rules = [
        "root ::= step m1" if max_steps > 1 else "root ::= step",
        "step ::= " + " | ".join(f"a{i}" for i in range(len(domain.actions))),
        "obj ::= " + " | ".join(_literal(o) for o in names),
    ]
    for i, action in enumerate(domain.actions):
        parts = [_literal("(" + action.name)] + ['" " obj'] * len(action.params) + ['")"']
        rules.append(f"a{i} ::= " + " ".join(parts))
    for i in range(1, max_steps):
        more = f" m{i + 1}" if i + 1 < max_steps else ""
        rules.append(f'm{i} ::= ("\\n" step{more})?')
    return "\n".join(rules) + "\n"


def _literal(text: str) -> str:
    if not all(c.isascii() and c.isprintable() for c in text):
        raise ValueError(f"grammar literal must be printable ASCII, got {text!r}")
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def plan_text(steps: Iterable[Step]) -> str:
    return "\n".join(map(str, steps))


__all__ = [
    "Outcome",
    "ParseStatus",
    "PlanParse",
    "Step",
    "Verdict",
    "judge",
    "parse_plan",
    "plan_gbnf",
    "plan_text",
    "simulate",
]
