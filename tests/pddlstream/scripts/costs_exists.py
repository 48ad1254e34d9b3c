"""Costs and an Exists goal, in PDDLStream's API style: two robots on a road map whose road
lengths come from init (``Equal``) and a ``:function``; the goal is that *some* robot reaches
the dock and the package is delivered."""

from __future__ import annotations

from pddlstream.algorithms.meta import create_parser, solve
from pddlstream.language.constants import And, Equal, Exists, PDDLProblem, print_solution
from pddlstream.language.function import FunctionInfo

DOMAIN = """
(define (domain roads)
  (:requirements :strips :action-costs :existential-preconditions)
  (:predicates (Robot ?r) (Place ?a) (Road ?a ?b) (At ?r ?a) (Package ?p) (PAt ?p ?a)
               (Carrying ?r ?p))
  (:functions (Length ?a ?b) (Handling))
  (:action drive :parameters (?r ?a ?b)
    :precondition (and (Robot ?r) (Road ?a ?b) (At ?r ?a))
    :effect (and (At ?r ?b) (not (At ?r ?a)) (increase (total-cost) (Length ?a ?b))))
  (:action load :parameters (?r ?p ?a)
    :precondition (and (At ?r ?a) (PAt ?p ?a) (Package ?p))
    :effect (and (Carrying ?r ?p) (not (PAt ?p ?a)) (increase (total-cost) (Handling))))
  (:action unload :parameters (?r ?p ?a)
    :precondition (and (At ?r ?a) (Carrying ?r ?p))
    :effect (and (PAt ?p ?a) (not (Carrying ?r ?p)) (increase (total-cost) (Handling)))))
"""

STREAMS = """
(define (stream roads)
  (:function (Length ?a ?b) (Road ?a ?b)))
"""

COORDS = {"depot": (0, 0), "north": (0, 10), "east": (10, 0), "dock": (10, 10), "far": (40, 40)}
ROADS = [
    ("depot", "north"),
    ("depot", "east"),
    ("north", "dock"),
    ("east", "dock"),
    ("far", "dock"),
]


def length(a: str, b: str) -> float:
    (x1, y1), (x2, y2) = COORDS[a], COORDS[b]
    return float(abs(x1 - x2) + abs(y1 - y2))


def make_problem() -> PDDLProblem:
    init = [Equal(("Handling",), 2)]
    init += [("Place", p) for p in COORDS]
    init += [("Road", a, b) for a, b in ROADS] + [("Road", b, a) for a, b in ROADS]
    init += [("Robot", "r1"), ("At", "r1", "far"), ("Robot", "r2"), ("At", "r2", "depot")]
    init += [("Package", "pkg"), ("PAt", "pkg", "north")]
    goal = And(Exists(["?r"], And(("Robot", "?r"), ("At", "?r", "dock"))), ("PAt", "pkg", "east"))
    return PDDLProblem(DOMAIN, {}, STREAMS, {"length": length}, init, goal)


STREAM_INFO = {"Length": FunctionInfo(opt_fn=lambda a, b: 10.0)}


def main() -> None:
    args = create_parser().parse_args()
    print_solution(
        solve(
            make_problem(),
            algorithm=args.algorithm,
            unit_costs=args.unit,
            stream_info=STREAM_INFO,
            max_time=60,
        )
    )


if __name__ == "__main__":
    main()
