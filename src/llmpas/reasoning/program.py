"""ProgPrompt-style answers: a Python program of robot calls, read as data.

The program is parsed with :mod:`ast` and never compiled or run. Each call of a known action with
string-constant arguments becomes the goal literal the action makes true; a later call on the same
first argument supersedes an earlier one (``pick("cube")`` then ``place("cube", "bowl")`` leaves
``(on cube bowl)``). The literals then go through the same validation as every other answer
(:func:`llmpas.reasoning.goal_reading.parse_goals`).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Mapping

from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, parse_goals
from llmpas.reasoning.tables import Call, Vocabulary

MAX_PROGRAM = 8_000
_FENCE = re.compile(r"```(?:python|py)?\s*\n(.*?)(?:```|$)", re.DOTALL)


def program_text(text: str) -> str:
    """The code of an answer: the last fenced block, or the whole text."""
    blocks = _FENCE.findall(text)
    return blocks[-1] if blocks else text


def parse_program(text: str, calls: Mapping[str, Call], vocab: Vocabulary) -> GoalParse:
    """Goals from a program answer; never runs anything."""
    code = program_text(text)
    if len(code) > MAX_PROGRAM:
        return GoalParse(GoalStatus.SYNTAX, (), (f"program too long ({len(code)} characters)",))
    try:
        tree = ast.parse(code)
    except (SyntaxError, ValueError, RecursionError, MemoryError) as e:
        where = f" at line {e.lineno}" if isinstance(e, SyntaxError) and e.lineno else ""
        return GoalParse(GoalStatus.SYNTAX, (), (f"not a Python program{where}: {e}",))
    literals: dict[str, str] = {}  # first argument -> literal text (later calls supersede)
    errors: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            _read_call(node, calls, literals, errors)
    if errors:
        status = (
            GoalStatus.UNKNOWN_PREDICATE
            if any("unknown action" in e for e in errors)
            else GoalStatus.SYNTAX
        )
        return GoalParse(status, (), tuple(errors))
    if not literals:
        return GoalParse(GoalStatus.EMPTY, (), ("the program calls none of the robot's actions",))
    return parse_goals("(and " + " ".join(literals.values()) + ")", vocab)


def _read_call(
    node: ast.Call, calls: Mapping[str, Call], literals: dict[str, str], errors: list[str]
) -> None:
    if not isinstance(node.func, ast.Name):
        errors.append('only plain calls of the robot\'s actions are allowed, e.g. pick("cube")')
        return
    name = node.func.id
    spec = calls.get(name)
    if spec is None:
        errors.append(f"unknown action {name!r}; actions: {', '.join(sorted(calls))}")
        return
    args = [a.value for a in node.args if isinstance(a, ast.Constant) and isinstance(a.value, str)]
    if len(args) != len(node.args) or node.keywords or len(args) != len(spec.params):
        errors.append(
            f"{name} takes {len(spec.params)} object name(s) as strings: {spec.signature(name)}"
        )
        return
    atom = "(" + " ".join([spec.predicate, *(args[i] for i in spec.positions)]) + ")"
    literals[args[0]] = f"(not {atom})" if spec.negated else atom
