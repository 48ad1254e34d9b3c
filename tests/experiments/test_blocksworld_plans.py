"""LLM plans for the blocks world are read as data and judged by simulating the domain: a corpus
of answers (well-formed, wrapped in prose, malformed), step-by-step failure messages, the plan
grammar, the tasks and their descriptions."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from llmpas.experiments.blocks.blocks_tasks import (
    TaskError,
    domain,
    generated_tasks,
    read_tasks,
    reference_plan,
    task_words,
    towers,
)
from llmpas.experiments.blocks.planners import EXAMPLE, EXAMPLE_PLAN, max_steps
from llmpas.experiments.blocks.plans import (
    Outcome,
    ParseStatus,
    Step,
    judge,
    parse_plan,
    plan_gbnf,
    simulate,
)

from ..tiny_model import needs_tiny_model, sample, tiny_backend

DATA = Path(__file__).resolve().parents[1] / "data" / "blocksworld"
OBJECTS = ("b1", "b2", "b3")


@pytest.mark.parametrize(
    ("answer", "expected"),
    [
        ("(pickup b3)\n(stack b3 b2)", ["(pickup b3)", "(stack b3 b2)"]),
        ("1. (pickup b3)\n2) (stack b3 b2)", ["(pickup b3)", "(stack b3 b2)"]),
        ("- (PICKUP B3)\n* (stack  b3 , b2)", ["(pickup b3)", "(stack b3 b2)"]),
        ("Step 1: (pickup b3)\nStep 2: (stack b3 b2)", ["(pickup b3)", "(stack b3 b2)"]),
        ("```lisp\n(pickup b3)\n(stack b3 b2)\n```", ["(pickup b3)", "(stack b3 b2)"]),
        ("(pickup b3) (stack b3 b2)", ["(pickup b3)", "(stack b3 b2)"]),
        (  # reasoning first: (clear b3) inside prose is not a step; only after "Plan:" counts
            "b3 is clear, since (clear b3) holds, so (unstack b1 b2) is not needed.\n"
            "Plan:\n1. (pickup b3)\n2. (stack b3 b2)\nThat is all.",
            ["(pickup b3)", "(stack b3 b2)"],
        ),
        (
            "First pick it up: (pickup b3), then put it on b2: (stack b3 b2).",
            ["(pickup b3)", "(stack b3 b2)"],
        ),
    ],
)
def test_tolerated_answers(answer: str, expected: list[str]) -> None:
    parse = parse_plan(answer, domain(), OBJECTS)
    assert parse.status is ParseStatus.OK, parse.errors
    assert [str(s) for s in parse.steps] == expected


@pytest.mark.parametrize(
    ("answer", "status", "error"),
    [
        ("(move b1 b2)", ParseStatus.SYNTAX_ERROR, "line 1: unknown action 'move'"),
        ("(pickup b3)\n(pick-up b1)", ParseStatus.SYNTAX_ERROR, "line 2: unknown action 'pick-up'"),
        ("(stack b1)", ParseStatus.SYNTAX_ERROR, "stack takes 2 argument(s) (?x ?y), got 1"),
        ("(pickup b1 b2)", ParseStatus.SYNTAX_ERROR, "pickup takes 1 argument(s) (?x), got 2"),
        ("(pickup b9)", ParseStatus.SYNTAX_ERROR, "unknown object 'b9' in (pickup b9)"),
        ("(pickup b1\n(stack b1 b2)", ParseStatus.SYNTAX_ERROR, "line 1: unbalanced parentheses"),
        ("()", ParseStatus.SYNTAX_ERROR, "line 1: empty step '()'"),
        ("1. (clear b2)", ParseStatus.SYNTAX_ERROR, "unknown action 'clear'"),
        ("", ParseStatus.NO_PLAN, "no plan steps found"),
        ("Pick up b3 and put it on b2.", ParseStatus.NO_PLAN, "no plan steps found"),
        ("Plan:\n", ParseStatus.NO_PLAN, "no plan steps found"),
    ],
)
def test_malformed_answers_are_rejected_with_a_reason(
    answer: str, status: ParseStatus, error: str
) -> None:
    parse = parse_plan(answer, domain(), OBJECTS)
    assert parse.status is status
    assert not parse.ok
    assert any(error in e for e in parse.errors), parse.errors


def test_a_syntax_error_is_a_failure_before_anything_runs() -> None:
    problem = generated_tasks([3], 1)[0].problem()
    verdict = judge(problem, parse_plan("(fly b1)", domain(), OBJECTS))
    assert verdict.outcome is Outcome.SYNTAX_ERROR
    assert verdict.executed == 0 and not verdict.success


def test_first_inapplicable_step_names_the_false_precondition() -> None:
    # bw3-s0: three blocks alone on the table; goal tower b2 b3 b1
    problem = generated_tasks([3], 1)[0].problem()
    bad = [Step("pickup", ("b3",)), Step("stack", ("b3", "b2")), Step("pickup", ("b2",))]
    verdict = simulate(problem, bad)
    assert verdict.outcome is Outcome.INAPPLICABLE
    assert verdict.message == "step 3 (pickup b2): precondition (clear b2) is false"
    assert (verdict.failed_step, verdict.executed) == (3, 2)


def test_a_plan_that_stops_early_misses_the_goal_facts() -> None:
    problem = generated_tasks([3], 1)[0].problem()
    verdict = simulate(problem, [Step("pickup", ("b3",)), Step("stack", ("b3", "b2"))])
    assert verdict.outcome is Outcome.GOAL_NOT_REACHED
    assert verdict.message == "after 2 steps the goal is not reached: (on b1 b3) is false"


def test_reference_plans_are_valid_and_the_in_context_example_too() -> None:
    assert simulate(EXAMPLE.problem(), EXAMPLE_PLAN).success
    for task in generated_tasks([3, 5, 7], 2, seed=5):
        ref = reference_plan(task)
        assert ref.length is not None and ref.length <= max_steps(task.size)
        assert simulate(task.problem(), ref.steps).success


def test_plan_grammar_lists_every_action_with_its_arity_and_bounds_the_length() -> None:
    text = plan_gbnf(domain(), OBJECTS, 3)
    assert 'a2 ::= "(stack" " " obj " " obj ")"' in text
    assert 'obj ::= "b1" | "b2" | "b3"' in text
    assert 'm2 ::= ("\\n" step)?' in text and "m3" not in text
    assert plan_gbnf(domain(), OBJECTS, 1).startswith("root ::= step\n")
    with pytest.raises(ValueError, match="max_steps"):
        plan_gbnf(domain(), OBJECTS, 0)
    with pytest.raises(ValueError, match="printable ASCII"):
        plan_gbnf(domain(), ('b"\n',), 2)


@needs_tiny_model
def test_llama_cpp_decodes_only_plans_the_grammar_admits() -> None:
    """llama.cpp samples under the plan grammar: every line is one step over the objects."""
    text = sample(tiny_backend(), plan_gbnf(domain(), OBJECTS, 3), "Stack b1 on b2.", 96)
    steps = text.split("\n")
    assert 1 <= len(steps) <= 3
    for step in steps:
        assert re.fullmatch(r"\((pickup|putdown|stack|unstack)( (b1|b2|b3))+\)", step), step


def test_generator_instances_differ_per_seed_and_describe_themselves() -> None:
    tasks = generated_tasks([3, 5, 7], 20)
    assert len(tasks) == 60 and len({t.text for t in tasks}) == 60
    assert {t.size for t in tasks} == {3, 5, 7}
    words = task_words(tasks[0].problem())
    assert "There are 3 blocks" in words and "b1 is on b3" in words
    assert "(on" not in words  # the first look sees words, not PDDL


def test_towers_are_listed_bottom_to_top() -> None:
    problem = generated_tasks([5], 1)[0].problem()  # bw5-s0: b5 b4 b1 b2 | b3
    assert towers(problem.init) == [["b3"], ["b5", "b4", "b1", "b2"]]


def test_problem_folder_is_read_sorted_with_sizes() -> None:
    tasks = read_tasks(DATA / "problems")
    assert [(t.name, t.size) for t in tasks] == [("four", 4), ("partial-goal", 3), ("six", 6)]
    partial = tasks[1].problem()
    ref = reference_plan(tasks[1])
    assert ref.length == 4 and simulate(partial, ref.steps).success


def test_malformed_problem_file_is_one_line_naming_it(tmp_path: Path) -> None:
    with pytest.raises(TaskError) as err:
        read_tasks(DATA / "malformed")
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(DATA / "malformed" / "bad.pddl"))
    (tmp_path / "x.pddl").write_text(
        "(define (problem x) (:domain logistics) (:objects a) (:init) (:goal (ontable a)))"
    )
    with pytest.raises(TaskError, match=r"x\.pddl.*not 'blocksworld'"):
        read_tasks(tmp_path)
    (tmp_path / "x.pddl").write_text(
        "(define (problem x) (:domain blocksworld) (:objects a) (:init) (:goal (ontable b)))"
    )
    with pytest.raises(TaskError, match=r"x\.pddl.*unknown object"):
        read_tasks(tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(TaskError, match=r"no \*\.pddl problem files"):
        read_tasks(tmp_path / "empty")
    with pytest.raises(TaskError, match="not a folder"):
        read_tasks(tmp_path / "missing")
