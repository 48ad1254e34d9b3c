"""The replan baseline: it answers every goal request with the task goal, in every method's form,
and in the closed loop it resolves an anomaly whose cause the robot perceived (state change) but
not one whose cause it must be told (object loss)."""

from __future__ import annotations

import pytest

from llmpas.experiments.suite import SUITE_DIR, Verdict, judge, load_task
from llmpas.experiments.worlds import LoopConfig
from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import parse_goals
from llmpas.reasoning.llm import Message, Request
from llmpas.reasoning.methods import Situation
from llmpas.reasoning.program import parse_program
from llmpas.reasoning.replan import FIRST_LOOK, LABEL, REPLAN, Replan, task_literals
from llmpas.worlds.household.household_plugin import household_for
from llmpas.worlds.household.household_reasoning import PROGRAM_CALLS, vocabulary

TASK = "(and (On apple bowl) (Heated bread))"


def _request(tag: str = "goals") -> Request:
    situation = Situation("anomaly", "", "", "", "", calls=PROGRAM_CALLS)
    return Request((Message("user", "whatever the prompt says"),), tag=tag, situation=situation)


def test_the_task_literals_are_read_and_restated_lower_case() -> None:
    assert task_literals(TASK) == (Atom("on", ("apple", "bowl")), Atom("heated", ("bread",)))
    assert task_literals("(not (Open fridge))") == (Not(Atom("open", ("fridge",))),)
    assert Replan(TASK).complete(_request()).text == "(and (on apple bowl) (heated bread))"
    for bad in ("(or (On a b) (On a c))", "(and (On a b)) (On a c)", "not pddl"):
        with pytest.raises(ValueError, match="task goal"):
            task_literals(bad)


def test_every_goal_request_gets_the_task_whatever_the_prompt() -> None:
    llm = Replan(TASK)
    first = llm.complete(_request("first-look"))
    assert first.text == FIRST_LOOK and first.model == REPLAN
    answers = {llm.complete(_request(tag)).text for tag in ("goals", "repair-1", "repair-2")}
    assert answers == {"(and (on apple bowl) (heated bread))"}


def test_the_answer_reads_back_as_the_task_in_each_methods_form() -> None:
    ol05 = load_task(SUITE_DIR / "ol05-drawer3.toml")  # an apple and a bowl
    vocab = vocabulary(household_for(ol05.scenario))
    goal = "(and (On apple bowl))"
    want = (Atom("on", ("apple", "bowl")),)
    assert parse_goals(Replan(goal).complete(_request()).text, vocab).goals == want
    program = Replan(goal, "progprompt").complete(_request()).text
    assert program == "place('apple', 'bowl')"
    assert parse_program(program, PROGRAM_CALLS, vocab).goals == want
    monologue = Replan(goal, "inner-monologue").complete(_request()).text
    assert monologue == "Robot action: place('apple', 'bowl')"


def test_in_the_loop_replan_resolves_a_perceived_cause_but_finds_nothing_lost() -> None:
    # state change: the dirt is seen, so replanning the task plans the washing itself
    sc02 = load_task(SUITE_DIR / "sc02-apple-stove.toml")
    j = judge(sc02, Replan(sc02.scenario.goal), LoopConfig())
    assert j.verdict is Verdict.SUCCESS and j.goals == ("(cooked apple)",)
    assert j.first_goals == "(cooked apple)" and j.first_effective is False  # not (cleaned apple)
    # object loss: where the mug went is not in the belief; the task alone cannot be planned
    ol02 = load_task(SUITE_DIR / "ol02-table1.toml")
    j = judge(ol02, Replan(ol02.scenario.goal), LoopConfig())
    assert j.verdict is Verdict.NOT_DONE and j.first_effective is False
    assert "location unknown" in j.message


def test_the_replan_row_says_what_it_is_and_asks_no_repairs() -> None:
    """No LLM is asked: the records never say "the LLM", and no repair is counted (the row
    showed repairs 1.00 and "the LLM gave no usable goals")."""
    ol01 = load_task(SUITE_DIR / "ol01-table2.toml")
    j = judge(ol01, Replan(ol01.scenario.goal), LoopConfig())
    assert j.verdict is Verdict.NOT_DONE
    assert j.message.startswith(f"{LABEL} gave no usable goals: "), j.message
    assert "the LLM" not in j.message
    assert j.repairs == 0 and j.answers == 1
