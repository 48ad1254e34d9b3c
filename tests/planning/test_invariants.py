"""The domain's invariants (:mod:`llmpas.planning.invariants`): found by Fast Downward's
translator from the action schemas and carried through derived predicates, so that a goal that
puts one object in two places is refused before any planner call, with its reason."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.language.domain import parse_domain, read_domain
from llmpas.language.logic import Atom, Not
from llmpas.language.streams import parse_streams, read_streams
from llmpas.planning.invariants import Invariants

KITCHEN = Path(__file__).parents[2] / "src" / "llmpas" / "worlds" / "kitchen"


def a(text: str) -> Atom:
    """``(p x y)`` as an atom."""
    words = text.strip("()").split()
    return Atom(words[0].lower(), tuple(words[1:]))


@pytest.fixture(scope="module")
def kitchen() -> Invariants:
    return Invariants.of(
        read_domain(KITCHEN / "domain.pddl"), read_streams(KITCHEN / "stream.pddl")
    )


# the apple stands at pose p1 on table1; p2 was sampled in the fridge
FACTS = frozenset(
    {a("(supported apple p1 table1)"), a("(atpose apple p1)"), a("(supported apple p2 fridge)")}
)


def test_the_translator_finds_one_pose_or_one_grasp_per_object(kitchen: Invariants) -> None:
    shown = [g.render() for g in kitchen.groups]
    assert "(atgrasp ?0 *), (atpose ?0 *)" in shown


def test_one_object_in_two_places_is_a_contradiction_with_its_reason(kitchen: Invariants) -> None:
    goals = [a("(on apple microwave)"), a("(on apple table2_right)"), a("(cooled apple)")]
    why = kitchen.contradiction(goals, FACTS)
    assert why.startswith("(on apple microwave) (on apple table2_right): cannot be achieved")
    assert "(atpose apple *)" in why and "(atgrasp apple *)" in why


def test_in_a_place_and_held_is_a_contradiction(kitchen: Invariants) -> None:
    assert kitchen.contradiction([a("(on apple sink)"), a("(holding apple)")], FACTS)


def test_what_may_hold_together_is_left_to_the_planner(kitchen: Invariants) -> None:
    assert not kitchen.contradiction([a("(on apple sink)"), a("(on mug sink)")], FACTS)
    assert not kitchen.contradiction([a("(on apple fridge)"), a("(cooled apple)")], FACTS)
    assert not kitchen.contradiction([Not(a("(on apple sink)")), a("(on apple table1)")], FACTS)
    assert kitchen.contradiction([a("(open fridge)"), Not(a("(open fridge)"))], FACTS)


def test_a_pose_on_two_regions_voids_the_inference(kitchen: Invariants) -> None:
    """Where the facts show one pose supported on two regions, ``Supported`` is not functional:
    the same pose could be on both, so nothing is claimed."""
    both = FACTS | {a("(supported apple p1 table2)")}
    assert not kitchen.contradiction([a("(on apple table1)"), a("(on apple table2)")], both)


def test_a_belief_that_breaks_the_invariant_voids_it(kitchen: Invariants) -> None:
    """Two poses believed at once: the invariant does not hold from there; no claim."""
    crowded = FACTS | {a("(atpose apple p2)")}
    assert not kitchen.contradiction([a("(on apple table1)"), a("(on apple fridge)")], crowded)


def test_a_stream_that_certifies_a_place_for_a_given_pose_voids_the_inference() -> None:
    """A stream whose output is the region (inputs the object and pose) may put an existing pose
    on a second region: ``Supported`` is then not functional."""
    domain = read_domain(KITCHEN / "domain.pddl")
    streams = parse_streams(
        "(define (stream s) (:stream region-of :inputs (?o ?p) :domain (Pose ?o ?p)"
        " :outputs (?r) :certified (Supported ?o ?p ?r)))"
    )
    inv = Invariants.of(domain, streams)
    assert not inv.contradiction([a("(on apple table1)"), a("(on apple fridge)")], FACTS)


LOGISTICS = """
(define (domain logistics-like)
  (:requirements :strips :typing)
  (:types package place truck)
  (:predicates (at ?p - package ?l - place) (in ?p - package ?t - truck) (truck-at ?t ?l))
  (:action load :parameters (?p - package ?t - truck ?l - place)
    :precondition (and (at ?p ?l) (truck-at ?t ?l))
    :effect (and (in ?p ?t) (not (at ?p ?l))))
  (:action unload :parameters (?p - package ?t - truck ?l - place)
    :precondition (and (in ?p ?t) (truck-at ?t ?l))
    :effect (and (at ?p ?l) (not (in ?p ?t))))
  (:action drive :parameters (?t - truck ?from ?to - place)
    :precondition (truck-at ?t ?from)
    :effect (and (truck-at ?t ?to) (not (truck-at ?t ?from)))))
"""


def test_a_domain_written_elsewhere_gets_its_own_invariants() -> None:
    inv = Invariants.of(parse_domain(LOGISTICS))
    facts = frozenset({a("(at p1 home)"), a("(truck-at t1 depot)")})
    assert inv.contradiction([a("(at p1 office)"), a("(in p1 t1)")], facts)
    assert inv.contradiction([a("(truck-at t1 office)"), a("(truck-at t1 home)")], facts)
    assert not inv.contradiction([a("(at p1 office)"), a("(truck-at t1 home)")], facts)
