"""PDDLStream's expressions and results as plain Python data.

Goals and init items are tuples, as in PDDLStream: ``And(a, b)`` is ``('and', a, b)``, a fact
is ``('AtPose', block, pose)`` whose arguments are any Python values, ``Equal(('Cost',), 1)`` is
``('=', ('Cost',), 1)``. A solution is ``Solution(plan, cost, certificate)``; its plan is a list
of ``Action(name, args)`` whose ``args`` are the user's own values.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, NamedTuple

INF = math.inf
EQ = "="
AND = "and"
OR = "or"
NOT = "not"
EXISTS = "exists"
FORALL = "forall"
IMPLY = "imply"
WHEN = "when"
MINIMIZE = "minimize"
MAXIMIZE = "maximize"
INCREASE = "increase"
PARAMETER = "?"
TOTAL_COST = "total-cost"
TOTAL_TIME = "total-time"
CONNECTIVES = (AND, OR, NOT, IMPLY)
QUANTIFIERS = (FORALL, EXISTS)
SUCCEEDED = True
FAILED = None
INFEASIBLE = False


class Action(NamedTuple):
    """One step of a plan: the action's name and its arguments (the user's values)."""

    name: str
    args: tuple[Any, ...]


class DurativeAction(NamedTuple):
    name: str
    args: tuple[Any, ...]
    start: float
    duration: float


class Certificate(NamedTuple):
    """Facts (tuples of values) true at the start: the init and every fact a stream certified;
    ``preimage_facts``: the certified facts the plan relies on."""

    all_facts: list[tuple[Any, ...]]
    preimage_facts: list[tuple[Any, ...]]


class Solution(NamedTuple):
    """``plan`` (a list of :class:`Action`, or None), its ``cost`` (INF without a plan) and the
    ``certificate``; unpacks as ``plan, cost, evaluations = solution``."""

    plan: list[Action] | None
    cost: float
    certificate: Certificate


def Output(*args: Any) -> tuple[Any, ...]:
    return tuple(args)


def And(*expressions: Any) -> Any:
    """A conjunction; of one expression: that expression."""
    return expressions[0] if len(expressions) == 1 else (AND, *expressions)


def Or(*expressions: Any) -> Any:
    return expressions[0] if len(expressions) == 1 else (OR, *expressions)


def Not(expression: Any) -> tuple[Any, ...]:
    return (NOT, expression)


def Imply(condition: Any, consequence: Any) -> tuple[Any, ...]:
    return (IMPLY, condition, consequence)


def Equal(left: Any, right: Any) -> tuple[Any, ...]:
    return (EQ, left, right)


def Minimize(expression: Any) -> tuple[Any, ...]:
    return (MINIMIZE, expression)


def Exists(parameters: Iterable[str], expression: Any) -> Any:
    params = tuple(parameters)
    return (EXISTS, params, expression) if params else expression


def ForAll(parameters: Iterable[str], expression: Any) -> Any:
    params = tuple(parameters)
    return (FORALL, params, expression) if params else expression


def Fact(predicate: str, args: Iterable[Any]) -> tuple[Any, ...]:
    return (predicate, *args)


def get_prefix(expression: Sequence[Any]) -> Any:
    return expression[0]


def get_args(head: Sequence[Any]) -> tuple[Any, ...]:
    return tuple(head[1:])


def is_parameter(expression: Any) -> bool:
    return isinstance(expression, str) and expression.startswith(PARAMETER)


def get_parameter_name(expression: Any) -> Any:
    return expression[len(PARAMETER) :] if is_parameter(expression) else expression


def is_plan(plan: Any) -> bool:
    return plan is not None and plan is not False


def get_length(plan: Sequence[Any] | None) -> float:
    return len(plan) if is_plan(plan) else INF  # type: ignore[arg-type]


def partition_facts(facts: Iterable[Any]) -> tuple[list[Any], list[Any], list[Any]]:
    """(objects, atoms, initial function values) of init facts."""
    functions = [f for f in facts if f[0] == EQ]
    atoms = [f for f in facts if f[0] != EQ]
    objects = sorted({a for f in atoms for a in f[1:]}, key=repr)
    return objects, atoms, functions


def is_cost(expression: Any) -> bool:
    return isinstance(expression, tuple) and bool(expression) and expression[0] == MINIMIZE


def get_costs(objectives: Iterable[Any]) -> list[Any]:
    return [o for o in objectives if is_cost(o)]


def get_constraints(objectives: Iterable[Any]) -> list[Any]:
    return [o for o in objectives if not is_cost(o)]


# --------------------------------------------------------------------------------- printing


def str_from_object(obj: Any) -> str:
    """A compact, deterministic text of nested containers (floats to 3 decimals)."""
    if isinstance(obj, float):
        return f"{obj:.3f}"
    if isinstance(obj, tuple) and hasattr(obj, "_fields"):  # a named tuple
        return repr(obj)
    if isinstance(obj, list | tuple):
        inner = ", ".join(map(str_from_object, obj))
        return f"[{inner}]" if isinstance(obj, list) else f"({inner}{',' if len(obj) == 1 else ''})"
    if isinstance(obj, set | frozenset):
        return "{" + ", ".join(sorted(map(str_from_object, obj))) + "}"
    if isinstance(obj, Mapping):
        items = sorted((str_from_object(k), str_from_object(v)) for k, v in obj.items())
        return "{" + ", ".join(f"{k}: {v}" for k, v in items) + "}"
    return str(obj)


def str_from_action(action: Sequence[Any]) -> str:
    name, args = action[0], action[1]
    return f"{name}({', '.join(map(str_from_object, args))})"


def str_from_plan(plan: Sequence[Any] | None) -> str:
    if not is_plan(plan):
        return str(plan)
    return "[" + ", ".join(map(str_from_action, plan or [])) + "]"


def print_plan(plan: Sequence[Any] | None) -> None:
    if not is_plan(plan):
        return
    for step, action in enumerate(plan or [], 1):
        print(f"{step:2d}) {action[0]} {' '.join(map(str_from_object, action[1]))}")


def print_solution(solution: Sequence[Any]) -> None:
    """What PDDLStream's ``print_solution`` shows: solved or not, cost, length, then the plan
    (this is an API whose contract is to print)."""
    plan, cost = solution[0], solution[1]
    facts = solution[2] if len(solution) > 2 else ()
    n = len(facts.all_facts) if isinstance(facts, Certificate) else len(facts or ())
    solved = is_plan(plan)
    print()
    print(f"Solved: {solved}")
    print(f"Cost: {cost:.3f}" if solved else f"Cost: {cost}")
    print(f"Length: {get_length(plan)}")
    print(f"Evaluations: {n}")
    print_plan(plan)


class PDDLProblem(NamedTuple):
    """A PDDLStream problem: PDDL texts, Python values and implementations."""

    domain_pddl: Any
    constant_map: Mapping[str, Any]
    stream_pddl: Any
    stream_map: Any
    init: Sequence[Any]
    goal: Any


DEBUG_MAPS = ("debug", "shared_debug")  # PDDLStream's stream_map of debug streams
