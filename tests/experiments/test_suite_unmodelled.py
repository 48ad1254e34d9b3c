"""The action-blocking and state-change tasks whose cause the domain does not model (ab06-ab08,
sc06-sc08): the anomaly's text names the cause, the belief holds no fact of it, replanning the
task alone fails, an effective set resolves it, and the oracle resolves it in l_gt actions."""

from __future__ import annotations

import pytest

from llmpas.experiments.suite import (
    SUITE_DIR,
    Category,
    Verdict,
    first_anomaly,
    judge,
    load_task,
    oracle_run,
    run_traced,
)
from llmpas.experiments.worlds import LoopConfig
from llmpas.language.logic import Atom
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.replan import Replan
from llmpas.worlds.household.household_oracle import oracle
from llmpas.worlds.household.state import HIDDEN

CAUSES = {
    "ab06-sink-mug": "mug is also in sink: sink can clean only one thing at a time",
    "ab07-stove-plate": "plate is also in stove: stove can cook only one thing at a time",
    "ab08-sink-occupied": "mug is also in sink: sink can clean only one thing at a time",
    "sc06-apple-frozen-stove": "apple is frozen: frozen food cannot be cooked",
    "sc07-bread-greasy-fridge": "bread is greasy: greasy things do not go into the fridge",
    "sc08-apple-waxed-stove": "apple is waxed: waxed fruit is not cooked",
}
QUICK = ("ab06-sink-mug", "sc06-apple-frozen-stove")


class Scripted:
    """Always the same answer."""

    name = "scripted"

    def __init__(self, answer: str) -> None:
        self.answer = answer

    def complete(self, request: Request) -> Response:
        return Response(self.answer, model="scripted")


def _check(name: str) -> None:
    task = load_task(SUITE_DIR / f"{name}.toml")
    assert task.measures_llm and task.category is not Category.OBJECT_LOSS
    traced = run_traced(task, oracle, LoopConfig())
    first = first_anomaly(traced.result)
    assert first is not None
    report = first[1]
    assert report.constraint == Atom(report.action, ())  # the skill's own failure
    assert CAUSES[name] in report.describe()
    assert not any(a.predicate in HIDDEN for a in report.belief)  # no fact says why
    assert traced.result.success
    # replanning the task alone repeats the failing process
    j = judge(task, Replan(task.scenario.goal), LoopConfig())
    assert j.verdict is Verdict.NOT_DONE and j.first_effective is False
    # the first effective set, proposed by an LLM, resolves it
    j = judge(task, Scripted(task.effective[0]), LoopConfig())
    assert j.success and j.first_effective is True
    run = oracle_run(task)
    assert run.issues == () and run.length == task.l_gt


@pytest.mark.parametrize("name", QUICK)
def test_unmodelled_causes_measure_the_llm(name: str) -> None:
    _check(name)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(set(CAUSES) - set(QUICK)))
def test_every_unmodelled_task_measures_the_llm(name: str) -> None:
    _check(name)


def test_a_wrong_fix_does_not_resolve_the_frozen_apple() -> None:
    # moving it to a table is no remedy: the apple stays frozen and the cooking fails again
    task = load_task(SUITE_DIR / "sc06-apple-frozen-stove.toml")
    j = judge(task, Scripted("(and (on apple table1_left))"), LoopConfig())
    assert not j.success and j.first_effective is False
