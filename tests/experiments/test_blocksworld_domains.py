"""Blocks-world files written for another naming of the four-operator domain (``on-table``,
``arm-empty``, ``pick-up``, ...) run unchanged with ``--domain``; the roles of the names are read
from the actions; a goal that already holds is solved by the empty plan."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments.blocks.blocks_tasks import (
    TaskError,
    domain,
    read_tasks,
    reference_plan,
    task_words,
)
from llmpas.experiments.blocks.planners import Settings, example_for, run_method
from llmpas.experiments.blocks.plans import Outcome, judge, parse_plan, simulate
from llmpas.experiments.blocks.roles import SHIPPED_ROLES, BlocksRoles, RolesError, detect_roles
from llmpas.experiments.blocksworld import BlocksConfig, run_blocksworld
from llmpas.language.domain import parse_domain
from llmpas.reasoning.llm import Request, Response

VARIANT = Path(__file__).resolve().parents[1] / "data" / "blocksworld" / "four_ops"
VARIANT_ROLES = BlocksRoles(
    on="on",
    ontable="on-table",
    clear="clear",
    holding="holding",
    handempty="arm-empty",
    pickup="pick-up",
    putdown="put-down",
    stack="stack",
    unstack="unstack",
)


class Scripted:
    def __init__(self, answer: str) -> None:
        self.answer = answer
        self.requests: list[Request] = []
        self.name = "scripted"

    def complete(self, request: Request) -> Response:
        self.requests.append(request)
        return Response(self.answer)


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def test_roles_are_read_from_the_actions_not_the_names() -> None:
    assert detect_roles(domain()) == SHIPPED_ROLES
    variant = parse_domain((VARIANT / "domain.pddl").read_text(), "variant.pddl")
    assert detect_roles(variant) == VARIANT_ROLES


def test_a_domain_that_is_not_a_blocks_world_is_named_in_one_line() -> None:
    text = """(define (domain lights) (:predicates (on ?l) (off ?l))
      (:action switch :parameters (?l) :precondition (off ?l)
        :effect (and (on ?l) (not (off ?l)))))"""
    with pytest.raises(RolesError, match=r"^lights\.pddl: not a four-operator blocks world"):
        detect_roles(parse_domain(text, "lights.pddl"))


def test_variant_files_load_and_their_reference_plans_are_valid() -> None:
    tasks = {t.name: t for t in read_tasks(VARIANT, VARIANT / "domain.pddl")}
    assert sorted(tasks) == ["p01-swap", "p02-already", "p03-tower"]
    assert tasks["p03-tower"].size == 4
    for task in tasks.values():
        ref = reference_plan(task)
        assert ref.length is not None
        assert simulate(task.problem(), ref.steps).success
    assert reference_plan(tasks["p02-already"]).length == 0
    assert "p03-tower is" not in task_words(tasks["p03-tower"].problem())
    assert "c1 is on c2" in task_words(tasks["p03-tower"].problem())
    assert "tower c1, c2, c3 (bottom to top)" in task_words(tasks["p03-tower"].problem())


def test_variant_problems_are_refused_against_the_shipped_domain() -> None:
    with pytest.raises(TaskError, match=r"p01-swap\.pddl"):
        read_tasks(VARIANT)


def test_the_empty_answer_is_judged_by_the_goal() -> None:
    tasks = {t.name: t for t in read_tasks(VARIANT, VARIANT / "domain.pddl")}
    for name, expected in (("p02-already", Outcome.SUCCESS), ("p01-swap", Outcome.NO_PLAN)):
        problem = tasks[name].problem()
        parse = parse_plan("I think nothing needs to move.", problem.domain, problem.objects)
        assert judge(problem, parse).outcome is expected


def test_the_in_context_example_is_written_in_the_domains_words() -> None:
    text = (VARIANT / "domain.pddl").read_text()
    task, plan = example_for(VARIANT_ROLES, "blocks-4op-variant", text)
    assert simulate(task.problem(), plan).success
    problem = read_tasks(VARIANT, VARIANT / "domain.pddl")[0].problem()
    llm = Scripted("(unstack b a)\n(put-down b)\n(pick-up a)\n(stack a b)")
    attempt = run_method("llm-ic", problem, llm, Settings(), text)
    assert attempt.verdict.success
    prompt = llm.requests[0].messages[-1].content
    assert "(pick-up b1)" in prompt and "(arm-empty)" in prompt
    assert "(pickup " not in prompt and "handempty" not in prompt


def test_the_oracle_row_solves_every_variant_file(tmp_path: Path) -> None:
    config = BlocksConfig(
        methods=("oracle", "llm-ic"),
        problems=VARIANT,
        domain=VARIANT / "domain.pddl",
        llm="oracle",
        out_dir=tmp_path,
    )
    report = run_blocksworld(config, quiet())
    assert len(report.outcomes) == 6
    assert all(o.success for o in report.outcomes), [o.message for o in report.outcomes]
    assert "(domain " in (tmp_path / "blocksworld.md").read_text()


def test_cli_takes_the_domain_and_refuses_it_without_problems(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["bench", "blocksworld", "--llm", "oracle", "--methods", "oracle"]
    assert main([*args, "--domain", str(VARIANT / "domain.pddl"), "--out", str(tmp_path)]) == 2
    assert "--domain needs --problems" in capsys.readouterr().err
    code = main(
        [*args, "--problems", str(VARIANT), "--domain", str(VARIANT / "domain.pddl"),
         "--out", str(tmp_path)]
    )  # fmt: skip
    assert code == 0
    assert "1.00 (1/1)" in capsys.readouterr().out
