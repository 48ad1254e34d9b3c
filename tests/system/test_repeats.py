"""When the loop plans an LLM's goals before the task
(:func:`llmpas.system.anomaly_memory.repeats_failure`): the joint plan repeats the step whose
failure
is the anomaly and nothing the robot believes says why. A tiny domain of a bowl a lid may
cover; no simulator, no planner."""

from __future__ import annotations

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.language.domain import parse_domain
from llmpas.language.logic import Atom, Formula, Not
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics
from llmpas.planning import Plan, PlanStep
from llmpas.system.anomaly_memory import repeats_failure, same_objects

DOMAIN = parse_domain(
    """(define (domain lidded)
         (:requirements :strips :negative-preconditions :derived-predicates)
         (:predicates (region ?r) (openable ?r) (open ?r) (holding ?o) (at ?o ?p ?r) (full ?r))
         (:derived (accessible ?r) (and (region ?r) (or (not (openable ?r)) (open ?r))))
         (:action place
           :parameters (?o ?p ?r)
           :precondition (and (holding ?o) (accessible ?r) (not (full ?r)))
           :effect (and (at ?o ?p ?r) (full ?r) (not (holding ?o)))))""",
    "lidded.pddl",
)
SEM = Semantics(DOMAIN, {}, {}, strict_costs=False)


def problem(*extra: Atom) -> Problem:
    init = [Atom("region", ("bowl",)), Atom("region", ("table",)), Atom("holding", ("cube",))]
    return Problem.create(
        DOMAIN,
        init=[*init, *extra],
        goal="(and (full bowl))",
        objects={"cube": "cube", "bowl": "bowl", "table": "table", "s1": (0.1, 0.2)},
    )


def report(constraint: Formula, action: str = "move-and-place") -> AnomalyReport:
    return AnomalyReport(
        action=action,
        args=("cube", "s0", "bowl"),
        steps=(0,),
        subtree=f"{action} cube s0 bowl",
        sub_action="check",
        constraint=constraint,  # type: ignore[arg-type]
        constraint_name="Uncovered",
        reason="lid lies over bowl, covering it",
        explored={},
        attempts=3,
        failures={},
        observations=(),
        belief=(),
    )


INTO_BOWL = Plan((PlanStep("place", ("cube", "s1", "bowl")),), 1.0)
ONTO_TABLE = Plan((PlanStep("place", ("cube", "s1", "table")),), 1.0)


def test_a_check_the_belief_holds_true_is_repeated_on_the_same_objects() -> None:
    failed = report(Atom("accessible", ("bowl",)))  # the belief says the bowl is accessible
    assert repeats_failure(SEM, failed, INTO_BOWL, problem())  # a new pose, the same bowl
    assert not repeats_failure(SEM, failed, ONTO_TABLE, problem())


def test_a_failure_the_belief_explains_is_not_repeated_unexplained() -> None:
    # the belief now says why: the bowl is openable and closed, so it is not accessible
    explained = problem(Atom("openable", ("bowl",)))
    assert not repeats_failure(SEM, report(Atom("accessible", ("bowl",))), INTO_BOWL, explained)
    # a negated literal (the bowl seen full) is a fact of the belief: the planner avoids it
    assert not repeats_failure(SEM, report(Not(Atom("full", ("bowl",)))), INTO_BOWL, problem())


def test_a_literal_outside_the_domain_or_of_another_arity_is_no_belief() -> None:
    assert not repeats_failure(SEM, report(Atom("kin", ("arm", "s1"))), INTO_BOWL, problem())
    assert not repeats_failure(SEM, report(Atom("accessible", ("bowl", "x"))), INTO_BOWL, problem())


def test_a_steps_own_failure_repeats_only_as_the_same_step() -> None:
    own = report(Atom("place", ()), action="place")
    same = Plan((PlanStep("place", ("cube", "s0", "bowl")),), 1.0)
    assert repeats_failure(SEM, own, same, problem())
    assert not repeats_failure(SEM, own, INTO_BOWL, problem())


def test_same_objects_compares_the_problems_own_objects_only() -> None:
    p = problem()
    assert same_objects(("cube", "s1", "bowl"), ("cube", "s0", "bowl"), p)
    assert not same_objects(("cube", "s1", "table"), ("cube", "s0", "bowl"), p)
    assert not same_objects(("cube", "s1"), ("cube", "s0", "bowl"), p)
