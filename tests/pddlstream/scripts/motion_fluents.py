"""A 2-D pick-and-place in PDDLStream's API style that needs a fluent stream: a gripper moves
on straight lines between confs; a motion is free only if it passes no block *currently* on the
table (closer than ``RADIUS`` to the block's centre), the held block excepted: the motion
stream declares ``:fluents (AtPose)``. The goal puts block B on a shelf below it; carrying B
down passes where B stood, so a planner that gave the motion stream the *initial* poses would
find no plan. Block A stands on the straight line from home to B's conf.

``CALLS`` records every motion call: its two confs, the fluent facts it got and its answer."""

from __future__ import annotations

import numpy as np
from pddlstream.algorithms.meta import create_parser, solve
from pddlstream.language.constants import And, PDDLProblem, print_solution
from pddlstream.language.generator import from_fn, from_gen_fn, from_test

DOMAIN = """
(define (domain motion2d)
  (:requirements :strips :equality :derived-predicates)
  (:predicates (Block ?b) (Region ?r) (Pose ?b ?p) (Conf ?q) (Kin ?b ?p ?q) (AtPose ?b ?p)
    (AtConf ?q) (HandEmpty) (Holding ?b) (CanMove) (Contained ?b ?p ?r) (Motion ?q1 ?t ?q2)
    (CFree ?b1 ?p1 ?b2 ?p2) (In ?b ?r) (Unsafe ?b ?p))
  (:action move :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))))
  (:action pick :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (Holding ?b) (CanMove) (not (AtPose ?b ?p)) (not (HandEmpty))))
  (:action place :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (Holding ?b) (AtConf ?q) (not (Unsafe ?b ?p)))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove) (not (Holding ?b))))
  (:derived (Unsafe ?b ?p)
    (exists (?b2 ?p2) (and (Pose ?b ?p) (Block ?b2) (not (= ?b ?b2)) (AtPose ?b2 ?p2)
                           (not (CFree ?b ?p ?b2 ?p2)))))
  (:derived (In ?b ?r) (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p)))))
"""

STREAMS = """
(define (stream motion2d)
  (:stream sample-pose :inputs (?b ?r) :domain (and (Block ?b) (Region ?r))
    :outputs (?p) :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))
  (:stream inverse-kinematics :inputs (?b ?p) :domain (Pose ?b ?p)
    :outputs (?q) :certified (and (Conf ?q) (Kin ?b ?p ?q)))
  (:stream test-cfree :inputs (?b1 ?p1 ?b2 ?p2) :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))
  (:stream plan-motion :inputs (?q1 ?q2) :domain (and (Conf ?q1) (Conf ?q2))
    :fluents (AtPose)
    :outputs (?t) :certified (Motion ?q1 ?t ?q2)))
"""

WIDTH = 1.0  # of a block, for placements
RADIUS = 0.6  # a motion passing closer than this to a block's centre hits it
GRASP = np.array([0.0, 1.0])  # the gripper's conf above a block's pose
REGIONS = {"shelf": (5.0, 7.0)}  # x range; shelf poses are at y = SHELF
SHELF = -3.0
START = {"A": np.array([3.0, 1.0]), "B": np.array([6.0, 0.0])}
HOME = np.array([0.0, 1.0])
CALLS: list[tuple[np.ndarray, np.ndarray, list[tuple], tuple | None]] = []


def pose_gen(block: str, region: tuple[float, float]):  # a deterministic sweep of the region
    lo, hi = region[0] + WIDTH / 2, region[1] - WIDTH / 2
    for x in np.linspace(lo, hi, 5):
        yield (np.array([x, SHELF]),)


def ik(block: str, pose: np.ndarray):
    return (pose + GRASP,)


def cfree(b1: str, p1: np.ndarray, b2: str, p2: np.ndarray) -> bool:
    return b1 == b2 or float(np.linalg.norm(p1 - p2)) >= WIDTH


def distance_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = 0.0 if not d.any() else float(np.clip(np.dot(p - a, d) / np.dot(d, d), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * d)))


def free(q1: np.ndarray, q2: np.ndarray, poses) -> bool:
    return all(distance_to_segment(p, q1, q2) >= RADIUS for p in poses)


def plan_motion(q1: np.ndarray, q2: np.ndarray, fluents=()):
    """A straight line from q1 to q2, or None when it passes a block on the table."""
    facts = list(fluents)
    assert all(name.lower() == "atpose" for name, _block, _pose in facts)
    out = (np.array([q1, q2]),) if free(q1, q2, [pose for _n, _b, pose in facts]) else None
    CALLS.append((q1, q2, facts, out))
    return out


def make_problem() -> PDDLProblem:
    init = [("HandEmpty",), ("CanMove",), ("Conf", HOME), ("AtConf", HOME)]
    init += [("Region", r) for r in REGIONS.values()]
    for b, p in START.items():
        init += [("Block", b), ("Pose", b, p), ("AtPose", b, p)]
    goal = And(("HandEmpty",), ("In", "B", REGIONS["shelf"]))
    stream_map = {
        "sample-pose": from_gen_fn(pose_gen),
        "inverse-kinematics": from_fn(ik),
        "test-cfree": from_test(cfree),
        "plan-motion": from_fn(plan_motion),
    }
    return PDDLProblem(DOMAIN, {}, STREAMS, stream_map, init, goal)


def main() -> None:
    parser = create_parser()
    args = parser.parse_args()
    solution = solve(make_problem(), algorithm=args.algorithm, unit_costs=args.unit, max_time=60)
    print_solution(solution)


if __name__ == "__main__":
    main()
