"""Substitution keeps the rest of the task (issue #35, item 3). On a scenario of its own
(tests/data/loop/stuck-drawer-two-chores.toml: two chores, the cube's drawer is stuck), the
labelled oracle's substitute (another drawer) is carried into the task and the apple is still
set out; before, the task was replanned with the stuck drawer in it and the run ended not done.
The rule itself on a tiny domain written here: no known cause, no substitution."""

from __future__ import annotations

from pathlib import Path

from llmpas.experiments.worlds import run_loop
from llmpas.language.domain import parse_domain
from llmpas.language.logic import And, Atom
from llmpas.reasoning.truth_oracle import ORACLE
from llmpas.system import loop_markdown
from tests.test_system import clean_blackboard  # noqa: F401 (autouse)

CHORES = str(Path(__file__).parent / "data" / "loop" / "stuck-drawer-two-chores.toml")
KITCHEN = parse_domain(
    (Path(__file__).parents[1] / "src/llmpas/worlds/kitchen/domain.pddl").read_text()
)


def test_a_substitute_is_carried_into_the_task_and_the_other_chore_is_done() -> None:
    result = run_loop(CHORES, ORACLE)
    assert result.success and result.truth, result.message
    assert "(on apple table2_right)" in result.task.lower()
    assert "drawer2" not in result.task and "(on cube drawer" in result.task.lower()
    assert len(result.substitutions) == 1 and "(jammed drawer2)" in result.substitutions[0]
    page = loop_markdown(result)
    assert "substituted:" in page and "jammed drawer2" in page


SHELVES = parse_domain(
    """(define (domain shelves)
         (:requirements :strips :negative-preconditions)
         (:predicates (box ?b) (shelf ?s) (stuck ?s) (dusty ?s) (at ?b ?s) (cracked ?b))
         (:action put :parameters (?b ?s)
                  :precondition (and (box ?b) (shelf ?s) (not (stuck ?s)) (not (cracked ?b))
                                     (not (dusty ?s)))
                  :effect (at ?b ?s))
         (:action dust :parameters (?s) :precondition (shelf ?s) :effect (not (dusty ?s))))"""
)
KINDS = {Atom("box", (b,)) for b in ("red", "blue", "green")}
KINDS |= {Atom("shelf", ("s1",)), Atom("shelf", ("s2",))}
TASK = And((Atom("at", ("red", "s1")), Atom("at", ("blue", "s2"))))


def test_a_static_fact_an_action_needs_false_is_a_known_cause() -> None:
    from llmpas.system.substitution import Causes, substitution

    causes = Causes.of(SHELVES)
    assert causes.blocking == {"stuck", "cracked"}  # dusty: an action changes it
    stuck = KINDS | {Atom("stuck", ("s1",))}
    found = substitution(TASK, [Atom("at", ("red", "s2"))], stuck, causes)
    assert found is not None and found.cause == Atom("stuck", ("s1",))
    other = substitution(
        TASK, [Atom("at", ("green", "s1"))], KINDS | {Atom("cracked", ("red",))}, causes
    )
    assert other is not None and other.replaced == Atom("at", ("red", "s1"))  # same kind


def test_no_known_cause_no_substitution() -> None:
    from llmpas.system.substitution import Causes, substitution

    causes = Causes.of(SHELVES)
    goals = [Atom("at", ("red", "s2"))]
    assert substitution(TASK, goals, KINDS, causes) is None  # nothing says why
    assert substitution(TASK, goals, KINDS | {Atom("dusty", ("s1",))}, causes) is None
    assert substitution(TASK, goals, KINDS | {Atom("stuck", ("s9",))}, causes) is None
    shelf = substitution(  # another object, not of the same kind: no substitute
        TASK, [Atom("at", ("s2", "s1"))], KINDS | {Atom("cracked", ("red",))}, causes
    )
    assert shelf is None


JUDGED = str(Path(__file__).parent / "data" / "loop" / "jammed-drawer-judged.toml")


def test_a_substitute_is_a_candidate_and_candidates_first_finishes_the_task() -> None:
    """Issue #42 item 6: the target drawer turns out jammed; another drawer serves (the judge's
    success says so). The blocked literal with another drawer is among the candidates, so the
    enumeration's own order (no model) finishes the task through it; before, every candidate
    failed the checks at the first consultation."""
    from llmpas.experiments.suite import load_task
    from llmpas.experiments.worlds import LoopConfig
    from llmpas.reasoning.methods import MethodConfig
    from llmpas.system.substitution import Causes, substitutes

    task = load_task(JUDGED)
    config = LoopConfig(method=MethodConfig(method="candidates-first"), success=task.success)
    result = run_loop(task.scenario, "oracle", config)
    assert result.success and result.truth, result.message
    first = next(r.proposal for r in result.rounds if r.proposal is not None)
    assert str(first.goals[0]) == "(on cube drawer1)"  # the first substitute, as enumerated
    assert len(result.substitutions) == 1 and "(jammed drawer2)" in result.substitutions[0]
    assert result.message.startswith("the substituted task (and (on cube drawer1)) is done")
    kinds = {Atom("drawer", (d,)) for d in ("drawer1", "drawer2", "drawer3")}
    facts = kinds | {Atom("jammed", ("drawer2",)), Atom("region", ("table1",))}
    found = substitutes(And((Atom("on", ("cube", "drawer2")),)), facts, Causes.of(KITCHEN), ())
    assert found == []  # no objects offered, no substitutes
    found = substitutes(
        And((Atom("on", ("cube", "drawer2")),)),
        facts,
        Causes.of(KITCHEN),
        ("drawer1", "drawer2", "drawer3", "table1", "cube"),
    )
    assert [str(g) for g in found] == ["(on cube drawer1)", "(on cube drawer3)"]
