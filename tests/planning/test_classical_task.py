"""A problem handed to Fast Downward as data (:class:`ClassicalTask`) is the same task as its
PDDL text: the translator writes the same SAS+ file both ways; bad data gets the parser's error."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.examples.tamp2d_pds import make_problem
from llmpas.planning import PlannerConfig, PlanStatus, solve
from llmpas.planning.downward import (
    ClassicalPlan,
    ClassicalStatus,
    ClassicalTask,
    DownwardConfig,
    FastDownward,
    TaskPlanner,
)

# derived predicates, forall / exists / imply, negation, equality, conditional and universal
# effects, types with constants, action costs from a function
SHOP_DOMAIN = """(define (domain shop)
  (:requirements :typing :negative-preconditions :derived-predicates :universal-preconditions
   :existential-preconditions :conditional-effects :action-costs :equality)
  (:types item box - object)
  (:constants depot - box)
  (:predicates (at ?i - item ?b - box) (open ?b - box) (heavy ?i - item) (full ?b - box)
               (marked ?x))
  (:functions (move-cost ?a - box ?b - box) - number (total-cost) - number)
  (:derived (full ?b - box) (exists (?i - item) (and (at ?i ?b) (heavy ?i))))
  (:action move
    :parameters (?i - item ?from ?to - box)
    :precondition (and (at ?i ?from) (open ?to) (not (full ?to)) (not (= ?from ?to)))
    :effect (and (at ?i ?to) (not (at ?i ?from)) (increase (total-cost) (move-cost ?from ?to))))
  (:action seal
    :parameters (?b - box)
    :precondition (and (open ?b) (forall (?i - item) (imply (at ?i ?b) (not (heavy ?i)))))
    :effect (and (not (open ?b)) (forall (?x) (when (marked ?x) (not (marked ?x))))
                 (increase (total-cost) 1))))
"""

BOXES = ("b1", "b2", "depot")


def shop_task(**changes: object) -> ClassicalTask:
    # "a" is untyped and sorts before typed objects: in the text it must not take their type
    values = [("total-cost", (), 0)]
    values += [("move-cost", (x, y), 1 + i + 2 * j) for i, x in enumerate(BOXES) for j, y in
               enumerate(BOXES)]  # fmt: skip
    fields: dict[str, object] = {
        "name": "shop-1",
        "domain_name": "shop",
        "objects": (("a", "object"), ("b1", "box"), ("b2", "box"), ("i1", "item"), ("I2", "item")),
        "init": (
            ("at", ("i1", "depot")),
            ("at", ("I2", "b1")),
            ("open", ("b1",)),
            ("open", ("b2",)),
            ("open", ("depot",)),
            ("heavy", ("i1",)),
            ("marked", ("a",)),
            ("at", ("i1", "depot")),  # a repeated fact
        ),
        "values": (*values, ("move-cost", ("depot", "elsewhere"), 5)),  # not an object: as text
        "goal": "(and (at i2 b2) (at i1 b2) (not (open b1)) (not (marked a))"
        " (forall (?i - item) (not (at ?i depot))))",
    }
    fields.update(changes)
    return ClassicalTask(**fields)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def planner() -> FastDownward:
    return FastDownward(DownwardConfig(max_time=30.0))


def test_data_and_text_give_the_same_sas_task(planner: FastDownward) -> None:
    task = shop_task()
    sas = planner.sas(SHOP_DOMAIN, task)
    assert sas == planner.sas(SHOP_DOMAIN, task.text)
    assert "move i1 depot b2" in sas and "seal b1" in sas
    by_data = planner.solve_task(SHOP_DOMAIN, task)
    assert by_data.solved
    assert by_data.actions == planner.solve(SHOP_DOMAIN, task.text).actions


def _no_text(**files: str) -> None:
    raise RuntimeError("the problem text was parsed")


def test_data_is_not_rendered_and_parsed_as_text(
    planner: FastDownward, monkeypatch: pytest.MonkeyPatch
) -> None:
    from fast_downward.translate import pddl_parser

    monkeypatch.setattr(pddl_parser, "open", _no_text)  # the forked translator inherits it
    assert planner.solve_task(SHOP_DOMAIN, shop_task()).solved
    by_text = planner.solve(SHOP_DOMAIN, shop_task().text)
    assert by_text.message == "translation failed: the problem text was parsed"
    # data the parser must judge goes to the parser
    bad = planner.solve_task(SHOP_DOMAIN, shop_task(init=(("lost", ("a",)),)))
    assert bad.message == "translation failed: the problem text was parsed"


def test_untyped_objects_keep_their_type_in_the_text(tmp_path: Path) -> None:
    from fast_downward.translate import pddl_parser

    (tmp_path / "domain.pddl").write_text(SHOP_DOMAIN)
    (tmp_path / "problem.pddl").write_text(shop_task().text)
    parsed = pddl_parser.open(str(tmp_path / "domain.pddl"), str(tmp_path / "problem.pddl"))
    types = {o.name: o.type_name for o in parsed.objects}
    # "a b1 - box" would make "a" a box too
    assert types == {"depot": "box", "a": "object", "b1": "box", "b2": "box", "i1": "item",
                     "i2": "item"}  # fmt: skip
    untyped = shop_task(objects=(("a", "object"), ("b", "object")))
    assert "(:objects a b)" in untyped.text


@pytest.mark.parametrize(
    "changes",
    [
        {"init": (("lost", ("a",)),)},  # undeclared predicate
        {"init": (("open", ("nowhere",)),)},  # unknown object
        {"init": (("open", ("b1", "b2")),)},  # arity
        {"objects": (("b1", "box"), ("B1", "box"))},  # duplicate object (case-insensitive)
        {"objects": (("depot", "box"),)},  # an object named like a constant
        {"values": (("total-cost", (), 0), ("total-cost", (), 1))},  # conflicting values
        {"values": (("total-cost", (), -1),)},  # negative value
        {"goal": "(and (at i1 b2)"},  # unbalanced goal
        {"goal": "(at i1 nowhere)"},  # unknown object in the goal
        {"domain_name": "other"},
        {"name": "shop 1"},  # a name the tokenizer splits
        {"objects": (("a(b", "object"),)},  # a name the tokenizer splits
    ],
)
def test_bad_data_gets_the_parsers_own_message(planner: FastDownward, changes: dict) -> None:
    task = shop_task(**changes)
    by_data = planner.solve_task(SHOP_DOMAIN, task)
    by_text = planner.solve(SHOP_DOMAIN, task.text)
    assert by_data.status is by_text.status
    assert by_data.status is not ClassicalStatus.SOLVED
    assert by_data.message == by_text.message and "\n" not in by_data.message


class Recorder:
    """Plans with Fast Downward (from data) and keeps every task it was given."""

    def __init__(self) -> None:
        self.planner = FastDownward(DownwardConfig(max_time=30.0))
        self.tasks: list[tuple[str, ClassicalTask]] = []

    def solve(self, domain_pddl: str, problem_pddl: str, *, max_time: float | None = None):
        raise AssertionError("the focused planner hands a task planner data, not text")

    def solve_task(
        self, domain_pddl: str, task: ClassicalTask, *, max_time: float | None = None
    ) -> ClassicalPlan:
        self.tasks.append((domain_pddl, task))
        return self.planner.solve_task(domain_pddl, task, max_time=max_time)


@pytest.mark.parametrize(("family", "defer"), [("packed", True), ("mirror", False)])
def test_bench_tamp_tasks_translate_the_same_from_data(
    family: str, defer: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    from fast_downward.translate import pddl_parser

    recorder = Recorder()
    assert isinstance(recorder, TaskPlanner)
    _, problem = make_problem(family, 3, 0)
    with monkeypatch.context() as patch:  # every task goes the data path
        patch.setattr(pddl_parser, "open", _no_text)
        result = solve(problem, PlannerConfig(defer=defer, max_time=60.0), classical=recorder)
    assert result.status is PlanStatus.SOLVED
    assert recorder.tasks
    for domain, task in recorder.tasks[:3]:
        assert recorder.planner.sas(domain, task) == recorder.planner.sas(domain, task.text)
