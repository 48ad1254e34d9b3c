"""A 2-D TAMP in PDDLStream's API style: blocks on a line, a gripper above, poses sampled in
regions, inverse kinematics, a collision test and a distance cost (numpy values)."""

from __future__ import annotations

import numpy as np
from pddlstream.algorithms.meta import create_parser, solve
from pddlstream.language.constants import TOTAL_COST, And, Equal, PDDLProblem, print_solution
from pddlstream.language.function import FunctionInfo
from pddlstream.language.generator import from_fn, from_gen_fn, from_test
from pddlstream.language.stream import StreamInfo

DOMAIN = """
(define (domain tamp2d)
  (:requirements :strips :equality :derived-predicates :action-costs)
  (:predicates (Block ?b) (Region ?r) (Pose ?b ?p) (Conf ?q) (Kin ?b ?p ?q) (AtPose ?b ?p)
    (AtConf ?q) (HandEmpty) (Holding ?b) (Contained ?b ?p ?r) (CFree ?b1 ?p1 ?b2 ?p2)
    (In ?b ?r) (Unsafe ?b ?p))
  (:functions (Dist ?q1 ?q2) (Cost))
  (:action move :parameters (?q1 ?q2)
    :precondition (and (Conf ?q1) (Conf ?q2) (AtConf ?q1))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (increase (total-cost) (Dist ?q1 ?q2))))
  (:action pick :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (Holding ?b) (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) (Cost))))
  (:action place :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (Holding ?b) (AtConf ?q) (not (Unsafe ?b ?p)))
    :effect (and (AtPose ?b ?p) (HandEmpty) (not (Holding ?b))
                 (increase (total-cost) (Cost))))
  (:derived (Unsafe ?b ?p)
    (exists (?b2 ?p2) (and (Pose ?b ?p) (Block ?b2) (not (= ?b ?b2)) (AtPose ?b2 ?p2)
                           (not (CFree ?b ?p ?b2 ?p2)))))
  (:derived (In ?b ?r) (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p)))))
"""

STREAMS = """
(define (stream tamp2d)
  (:stream sample-pose :inputs (?b ?r) :domain (and (Block ?b) (Region ?r))
    :outputs (?p) :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))
  (:stream inverse-kinematics :inputs (?b ?p) :domain (Pose ?b ?p)
    :outputs (?q) :certified (and (Conf ?q) (Kin ?b ?p ?q)))
  (:stream test-cfree :inputs (?b1 ?p1 ?b2 ?p2) :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))
  (:function (Dist ?q1 ?q2) (and (Conf ?q1) (Conf ?q2))))
"""

WIDTH = 1.0
REGIONS = {"table": (-10.0, 0.0), "goal": (4.0, 8.0)}
START = {"A": np.array([-6.0, 0.0]), "B": np.array([-3.0, 0.0])}
HOME = np.array([0.0, 5.0])


def pose_gen(block: str, region: tuple[float, float]):  # a deterministic sweep of the region
    lo, hi = region[0] + WIDTH / 2, region[1] - WIDTH / 2
    for x in np.linspace(lo, hi, 9):
        yield (np.array([x, 0.0]),)


def ik(block: str, pose: np.ndarray):
    return (pose + np.array([0.0, 2.0]),)


def cfree(b1: str, p1: np.ndarray, b2: str, p2: np.ndarray) -> bool:
    return b1 == b2 or abs(float(p1[0] - p2[0])) >= WIDTH


def distance(q1: np.ndarray, q2: np.ndarray) -> float:
    return 1.0 + float(np.abs(q2 - q1).sum())


def make_problem(goal_blocks: tuple[str, ...] = ("A", "B")) -> PDDLProblem:
    init = [
        ("HandEmpty",),
        ("Conf", HOME),
        ("AtConf", HOME),
        Equal(("Cost",), 1),
        Equal((TOTAL_COST,), 0),
    ]
    init += [("Region", r) for r in REGIONS.values()]
    for b, p in START.items():
        init += [("Block", b), ("Pose", b, p), ("AtPose", b, p)]
    goal = And(("HandEmpty",), *[("In", b, REGIONS["goal"]) for b in goal_blocks])
    stream_map = {
        "sample-pose": from_gen_fn(pose_gen),
        "inverse-kinematics": from_fn(ik),
        "test-cfree": from_test(cfree),
        "dist": distance,
    }
    return PDDLProblem(DOMAIN, {}, STREAMS, stream_map, init, goal)


STREAM_INFO = {
    "test-cfree": StreamInfo(p_success=1.0, verbose=False),
    "dist": FunctionInfo(opt_fn=lambda q1, q2: 1.0),
}


def main() -> None:
    parser = create_parser()
    args = parser.parse_args()
    solution = solve(
        make_problem(),
        algorithm=args.algorithm,
        unit_costs=args.unit,
        stream_info=STREAM_INFO,
        max_time=60,
    )
    print_solution(solution)


if __name__ == "__main__":
    main()
