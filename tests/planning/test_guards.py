"""Guarded universal preconditions: the same plans from Fast Downward, far fewer ground axioms."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.language.domain import parse_domain
from llmpas.language.logic import Atom, Exists, Not
from llmpas.planning.downward import ClassicalStatus, DownwardConfig, FastDownward
from llmpas.planning.guards import GUARD_PREFIX, free_variables, guard_quantifiers

# `place` may put ?b at ?p only when every block standing somewhere is clear of ?p: the shape of
# PDDLStream's 2-D example. Spot is static (no action changes it), so it guards ?b ?p.
DOMAIN = """
(define (domain spots)
 (:requirements :strips :equality :universal-preconditions)
 (:predicates (Spot ?b ?p) (At ?b ?p) (Clear ?b ?p ?b2 ?p2) (Holding ?b) (Moved ?b)
  (Loose ?b))
 (:action place :parameters (?b ?p)
  :precondition (and (Spot ?b ?p) (Holding ?b)
                     (forall (?b2 ?p2) (imply (and (Spot ?b2 ?p2) (At ?b2 ?p2))
                                              (Clear ?b ?p ?b2 ?p2))))
  :effect (and (At ?b ?p) (Moved ?b) (not (Holding ?b))))
 (:action lift :parameters (?b ?p)
  :precondition (and (At ?b ?p) (Loose ?b))
  :effect (and (Holding ?b) (not (At ?b ?p)))))
"""


def problem(n_free: int, clear: bool) -> str:
    """Block a at p0 is lifted and placed at p1, next to block c standing at p2; ``n_free``
    other objects make the object count large. p1 is clear of p2 exactly when ``clear``; c cannot
    be lifted."""
    extra = " ".join(f"x{i}" for i in range(n_free))
    clear_fact = "(Clear a p1 c p2)" if clear else ""
    return f"""(define (problem p) (:domain spots) (:objects a c p0 p1 p2 {extra})
     (:init (Spot a p0) (Spot a p1) (Spot c p2) (At a p0) (At c p2) (Loose a) {clear_fact})
     (:goal (and (At a p1) (Moved a))))"""


def test_the_forall_becomes_a_negated_guarded_derived_predicate() -> None:
    domain = guard_quantifiers(parse_domain(DOMAIN))
    (rule,) = domain.derived
    assert rule.head.name == f"{GUARD_PREFIX}place__2"
    assert [p.name for p in rule.head.params] == ["?b", "?p"]
    guard, violated = rule.body.parts  # type: ignore[union-attr]
    assert guard.parts == (Atom("spot", ("?b", "?p")),)  # type: ignore[union-attr]
    assert isinstance(violated, Exists) and isinstance(violated.body, Not)
    place = next(a for a in domain.actions if a.name == "place")
    assert Not(Atom(rule.head.name, ("?b", "?p"))) in place.precondition.parts  # type: ignore[union-attr]
    lift = next(a for a in domain.actions if a.name == "lift")
    assert lift == parse_domain(DOMAIN).actions[1]


def test_a_forall_without_static_atoms_over_its_variables_is_left_alone() -> None:
    text = DOMAIN.replace("(Spot ?b ?p) (Holding ?b)", "(Holding ?b)")
    domain = parse_domain(text)
    assert guard_quantifiers(domain) is domain


@pytest.mark.parametrize("clear", [True, False])
def test_fast_downward_answers_the_same_with_and_without_the_guard(clear: bool) -> None:
    planner = FastDownward(DownwardConfig(max_time=30.0))
    domain = parse_domain(DOMAIN)
    plain = planner.solve(domain.to_pddl(), problem(3, clear))
    guarded = planner.solve(guard_quantifiers(domain).to_pddl(), problem(3, clear))
    expected = ClassicalStatus.SOLVED if clear else ClassicalStatus.UNSOLVABLE
    assert plain.status is guarded.status is expected
    assert plain.actions == guarded.actions


def _ground_axioms(tmp_path: Path, domain: str, task: str) -> int:
    from fast_downward.translate import instantiate, normalize, options, pddl_parser

    (tmp_path / "d.pddl").write_text(domain)
    (tmp_path / "p.pddl").write_text(task)
    options.set_options([str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl")])
    parsed = pddl_parser.open(
        domain_filename=str(tmp_path / "d.pddl"), problem_filename=str(tmp_path / "p.pddl")
    )
    normalize.normalize(parsed)
    axioms = instantiate.explore(parsed)[4]
    return len(axioms)


def test_the_guard_keeps_grounding_from_growing_with_the_square_of_the_objects(
    tmp_path: Path,
) -> None:
    domain = parse_domain(DOMAIN)
    task = problem(40, True)
    plain = _ground_axioms(tmp_path, domain.to_pddl(), task)
    guarded = _ground_axioms(tmp_path, guard_quantifiers(domain).to_pddl(), task)
    assert plain >= 45 * 45  # every (?b, ?p) pair of the 45 objects
    assert guarded <= 10  # the two Spot facts of block a, and c's


def test_free_variables_leave_out_quantified_ones() -> None:
    domain = parse_domain(DOMAIN)
    place = domain.actions[0]
    forall = place.precondition.parts[2]  # type: ignore[union-attr]
    assert free_variables(forall) == {"?b", "?p"}
