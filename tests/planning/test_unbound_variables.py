"""A variable bound nowhere in a domain's condition names no object, as in the Fast Downward
translator that PDDLStream ships (its ``continuous_tamp/ffrob`` domain has one): the atom over
it is false in every state and its negation true. Each case here was planned by that
translator too (caelan/downward at 11e98c5) with the same outcome: ``ok`` never holds although
an existential reading would make it hold; ``bad`` holds although ``(n x ?p)`` holds for every
object ``?p`` (so neither an existential nor a universal reading)."""

from __future__ import annotations

import pytest

from llmpas.language.domain import parse_domain
from llmpas.language.problem import Problem
from llmpas.planning import PlannerConfig, PlanStatus, solve

DOMAIN = """(define (domain free)
  (:requirements :strips :derived-predicates)
  (:predicates (g ?b ?p) (h ?b ?g) (ok ?b) (done ?b) (n ?b ?p) (bad ?b))
  (:derived (ok ?b) (exists (?g) (and (h ?b ?g) (g ?b ?p1))))
  (:derived (bad ?b) (and (h ?b ?b) (not (n ?b ?p2))))
  (:action a :parameters (?b) :precondition (ok ?b) :effect (done ?b))
  (:action c :parameters (?b) :precondition (bad ?b) :effect (done ?b)))
"""


@pytest.mark.parametrize(
    ("init", "plan"),
    [
        ([("h", "x", "y"), ("g", "x", "y")], None),
        ([("h", "x", "x"), ("n", "x", "y")], ["c"]),
        ([("h", "x", "x"), ("n", "x", "y"), ("n", "x", "x")], ["c"]),
    ],
)
def test_an_atom_over_an_unbound_variable_is_false(init, plan) -> None:
    problem = Problem.create(parse_domain(DOMAIN), init=init, goal=[("done", "x")])
    result = solve(problem, PlannerConfig(max_iterations=3))
    if plan is None:
        assert result.status is PlanStatus.UNSOLVABLE
    else:
        assert result.status is PlanStatus.SOLVED
        assert [s.action for s in result.plan.steps] == plan
