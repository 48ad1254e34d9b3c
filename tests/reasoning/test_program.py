"""ProgPrompt answers are parsed with ast, never run, and mapped to validated goal literals."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import GoalStatus
from llmpas.reasoning.program import parse_program
from llmpas.worlds.household.household_problem import Household
from llmpas.worlds.household.household_reasoning import PROGRAM_CALLS, vocabulary
from llmpas.worlds.household.layout import default_objects, kitchen

VOCAB = vocabulary(Household(kitchen(), default_objects()))


def read(text: str):  # type: ignore[no-untyped-def]
    return parse_program(text, PROGRAM_CALLS, VOCAB)


def test_calls_become_goals_and_later_calls_supersede() -> None:
    parse = read(
        "```python\ndef recover():\n    scan_table('table2_right')\n"
        "    pick('cube')\n    place('cube', 'bowl')\n```"
    )
    assert parse.ok
    assert set(parse.goals) == {Atom("scanned", ("table2_right",)), Atom("on", ("cube", "bowl"))}


def test_close_is_a_negated_goal() -> None:
    parse = read("open('fridge')\nclose('fridge')")
    assert parse.goals == (Not(Atom("open", ("fridge",))),)


def test_nothing_is_ever_executed(tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    hostile = [
        f"import os\nos.system('touch {marker}')",
        f"__import__('os').system('touch {marker}')",
        f"open('{marker}', 'w').write('x')",
        f"exec(\"open('{marker}', 'w')\")",
        f"eval(compile(\"open('{marker}','w')\", 'x', 'exec'))",
    ]
    for text in hostile:
        parse = read(text)
        assert not parse.ok and parse.errors, text
    assert not marker.exists()


@pytest.mark.parametrize(
    ("text", "status", "word"),
    [
        ("def recover(:\n    pick('cube')", GoalStatus.SYNTAX, "line 1"),
        ("teleport('cube')", GoalStatus.UNKNOWN_PREDICATE, "teleport"),
        ("pick(cube)", GoalStatus.SYNTAX, "strings"),
        ("pick('cube', 'bowl')", GoalStatus.SYNTAX, "pick"),
        ("robot.pick('cube')", GoalStatus.SYNTAX, "plain calls"),
        ("x = 1 + 1", GoalStatus.EMPTY, "none of the robot's actions"),
        ("pick('unicorn')", GoalStatus.UNKNOWN_OBJECT, "unicorn"),
        ("place('table1_left', 'cube')", GoalStatus.WRONG_KIND, "table1_left"),
        ("pick('cube')\n" * 5000, GoalStatus.SYNTAX, "too long"),
    ],
)
def test_bad_programs_are_rejected_clearly(text: str, status: GoalStatus, word: str) -> None:
    parse = read(text)
    assert parse.status is status
    assert any(word in e for e in parse.errors), parse.errors
