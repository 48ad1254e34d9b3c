"""``replan``: the no-reasoning baseline, a recovery method that asks no model (like ``oracle``,
:mod:`llmpas.reasoning.truth_oracle`): ``llmpas run --llm replan`` and the ``replan`` row of
``bench prompting`` (a baseline, not an oracle).

An LLM backend that answers every goal request with the task goal itself, restated: whatever the
anomaly, it proposes "do the task again". Run in the same closed loop with the same budget as
every method, it measures what replanning the task from the robot's belief achieves on its own;
a method's *lift* over it is what its reasoning adds. It reads nothing but the task goal it was
built with (never the world's truth, never the prompt). It is a
:class:`~llmpas.reasoning.llm.Baseline`: the loop's records name it (never "the LLM") and the loop
asks it for no repairs (a restatement does not change with the errors shown).

The answer's form follows the prompting method the loop uses (``flp``, like the oracle row, by
default): a PDDL conjunction for the goal methods, one action call per literal for
``progprompt`` and ``inner-monologue`` (their answers are programs), taken from the request's
situation (its ``calls``) when it has one.
"""

from __future__ import annotations

from collections.abc import Mapping

from llmpas.language.logic import Atom, Not
from llmpas.language.sexpr import SList, Sym, parse_all
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.tables import Call

REPLAN = "replan"
FIRST_LOOK = "No reasoning: do the task again from what the robot now believes."
LABEL = "replan (no LLM: the task restated)"  # what answers, in the loop's records


def task_literals(goal: str) -> tuple[Atom | Not, ...]:
    """The literals of a task goal (a literal or a conjunction of literals), lower-cased as the
    goal reader writes them. ValueError for anything else."""
    exprs = parse_all(goal, "task goal")
    if len(exprs) != 1 or not isinstance(exprs[0], SList):
        raise ValueError(f"task goal: not one formula: {goal!r}")
    top = exprs[0]
    items = top.items[1:] if top.head() == "and" else [top]
    return tuple(_literal(i, goal) for i in items)


def _literal(e: object, goal: str) -> Atom | Not:
    if isinstance(e, SList) and e.head() == "not" and len(e.items) == 2:
        inner = _literal(e.items[1], goal)
        if isinstance(inner, Atom):
            return Not(inner)
    if isinstance(e, SList) and e.items and all(isinstance(a, Sym) for a in e.items):
        name, *args = (str(a).lower() for a in e.items)
        return Atom(name, tuple(args))
    raise ValueError(f"task goal: not a conjunction of literals: {goal!r}")


class Replan:
    """Answers every goal request with the task goal restated (``first-look``: a fixed line)."""

    name = REPLAN
    role = LABEL
    repairs = 0  # a restatement does not change with the errors shown

    def __init__(self, task: str, method: str = "flp") -> None:
        self.literals = task_literals(task)
        self.method = method

    def complete(self, request: Request) -> Response:
        if request.tag == "first-look":
            return Response(FIRST_LOOK, model=REPLAN)
        calls = getattr(request.situation, "calls", None)
        from llmpas.reasoning.methods import REGISTRY  # methods names this baseline

        method = REGISTRY.get(self.method)
        if method is not None and method.program and calls:
            return Response(self.program(calls), model=REPLAN)
        return Response(self.goals(), model=REPLAN)

    def goals(self) -> str:
        return f"(and {' '.join(map(str, self.literals))})"

    def program(self, calls: Mapping[str, Call]) -> str:
        """The task as action calls (the last call of an Inner-Monologue answer is read)."""
        lines = []
        for lit in self.literals:
            atom = lit.arg if isinstance(lit, Not) else lit
            if not isinstance(atom, Atom):
                continue
            for name, call in calls.items():
                if call.predicate != atom.predicate or call.negated != isinstance(lit, Not):
                    continue
                if len(call.positions) != len(atom.args):
                    continue
                args = ["?"] * len(call.params)
                for pos, value in zip(call.positions, atom.args, strict=True):
                    args[pos] = value
                if "?" not in args:
                    lines.append(f"{name}({', '.join(repr(a) for a in args)})")
                    break
        from llmpas.reasoning.methods import REGISTRY

        if REGISTRY[self.method].reader == "skill":
            return "Robot action: " + (lines[-1] if lines else "done()")
        return "\n".join(lines) or "pass"


__all__ = ["FIRST_LOOK", "LABEL", "REPLAN", "Replan", "task_literals"]
