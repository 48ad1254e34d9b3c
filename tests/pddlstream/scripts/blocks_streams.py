"""A blocks world with streams, in PDDLStream's API style: blocks are Python objects; a test
says which block may go on which (by size) and a list function gives each block's grips."""

from __future__ import annotations

from dataclasses import dataclass

from pddlstream.algorithms.meta import create_parser, solve
from pddlstream.language.constants import And, PDDLProblem, print_solution
from pddlstream.language.generator import from_list_fn, from_test


@dataclass(frozen=True)
class Block:
    name: str
    size: int

    def __str__(self) -> str:
        return self.name


DOMAIN = """
(define (domain blocks-streams)
  (:requirements :strips)
  (:predicates (Block ?b) (Grip ?b ?g) (Stackable ?a ?b) (On ?a ?b) (OnTable ?a) (Clear ?a)
               (HandEmpty) (Holding ?a ?g))
  (:action pickup :parameters (?a ?g)
    :precondition (and (Grip ?a ?g) (Clear ?a) (OnTable ?a) (HandEmpty))
    :effect (and (Holding ?a ?g) (not (OnTable ?a)) (not (Clear ?a)) (not (HandEmpty))))
  (:action putdown :parameters (?a ?g)
    :precondition (Holding ?a ?g)
    :effect (and (OnTable ?a) (Clear ?a) (HandEmpty) (not (Holding ?a ?g))))
  (:action stack :parameters (?a ?g ?b)
    :precondition (and (Holding ?a ?g) (Clear ?b) (Stackable ?a ?b))
    :effect (and (On ?a ?b) (Clear ?a) (HandEmpty) (not (Holding ?a ?g)) (not (Clear ?b))))
  (:action unstack :parameters (?a ?g ?b)
    :precondition (and (Grip ?a ?g) (On ?a ?b) (Clear ?a) (HandEmpty))
    :effect (and (Holding ?a ?g) (Clear ?b) (not (On ?a ?b)) (not (Clear ?a))
                 (not (HandEmpty)))))
"""

STREAMS = """
(define (stream blocks-streams)
  (:stream grips :inputs (?b) :domain (Block ?b) :outputs (?g) :certified (Grip ?b ?g))
  (:stream stackable :inputs (?a ?b) :domain (and (Block ?a) (Block ?b))
    :certified (Stackable ?a ?b)))
"""

A, B, C = Block("a", 1), Block("b", 2), Block("c", 3)


def grips(block: Block) -> list[tuple[str]]:
    return [(f"top-{block.name}",)]


def stackable(upper: Block, lower: Block) -> bool:
    return upper.size < lower.size


def make_problem() -> PDDLProblem:
    # c on a (too big for it; allowed at the start), b on the table: build a tower a-b-c
    init = [
        ("HandEmpty",),
        ("OnTable", A),
        ("On", C, A),
        ("Clear", C),
        ("OnTable", B),
        ("Clear", B),
    ]
    init += [("Block", x) for x in (A, B, C)]
    goal = And(("On", A, B), ("On", B, C))
    stream_map = {"grips": from_list_fn(grips), "stackable": from_test(stackable)}
    return PDDLProblem(DOMAIN, {}, STREAMS, stream_map, init, goal)


def main() -> None:
    args = create_parser().parse_args()
    print_solution(
        solve(make_problem(), algorithm=args.algorithm, unit_costs=args.unit, max_time=60)
    )


if __name__ == "__main__":
    main()
