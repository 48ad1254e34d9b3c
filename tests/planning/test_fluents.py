"""Fluent streams with llmpas's native API, on stream and domain files: a grasp exists only
while no block is on the grasped one, so the stream must see the state where the grasp is used,
not the initial one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from llmpas.language.bindings import function, sampler
from llmpas.language.domain import parse_domain
from llmpas.language.logic import Atom
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanStatus, solve

DATA = Path(__file__).parent / "data" / "fluents"


def stack(calls: list[tuple[str, list[Any]]]) -> Problem:
    def grasp(block: str, fluents: list[Any]) -> tuple[str] | None:
        calls.append((block, list(fluents)))
        covered = any(f[0] == "on" and f[2] == block for f in fluents)
        return None if covered else (f"top-of-{block}",)

    return Problem.create(
        parse_domain((DATA / "domain.pddl").read_text()),
        parse_streams((DATA / "stream.pddl").read_text()),
        init=[
            ("Block", "a"),
            ("Block", "b"),
            ("On", "a", "b"),
            ("On", "b", "table"),
            ("HandEmpty",),
        ],
        goal=[("Holding", "b")],
        implementations={"grasp": function(grasp)},
    )


def test_a_fluent_stream_sees_the_state_of_the_step_that_uses_it() -> None:
    calls: list[tuple[str, list[Any]]] = []
    problem = stack(calls)
    result = solve(problem, PlannerConfig(defer=False, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    plan = result.plan
    assert plan is not None
    assert [(s.action, s.args[0]) for s in plan.steps] == [
        ("pick", "a"),
        ("put", "a"),
        ("pick", "b"),
    ]
    # b's grasp was refused while a was on b, then given where a is on the table (fluent
    # facts come as PDDLStream gives them: tuples, objects by value, here their names)
    assert ("b", [("on", "a", "b"), ("on", "b", "table")]) in calls
    assert ("b", [("on", "a", "table"), ("on", "b", "table")]) in calls
    # the plan says in which state its grasp of b holds, and that state is the step's
    used = Atom("grasp", ("b", plan.steps[2].args[2]))
    assert plan.fluent_facts[used] == {
        frozenset({Atom("on", ("a", "table")), Atom("on", ("b", "table"))})
    }
    sem = Semantics(problem.domain, problem.object_types)
    steps = [(s.action, s.args) for s in plan.steps]
    states = replay(sem, problem.init | plan.certified, steps, problem.goal).states
    assert {a for a in states[2] if a.predicate == "on"} in plan.fluent_facts[used]


def test_incremental_planning_refuses_fluent_streams_in_one_line() -> None:
    result = solve(stack([]), PlannerConfig(algorithm="incremental", defer=False, max_time=60))
    assert result.status is PlanStatus.ERROR
    assert "':fluents' needs the focused algorithm" in result.message
    assert "\n" not in result.message


TIGHT_DOMAIN = """
(define (domain tight)
  (:requirements :strips :equality :derived-predicates)
  (:predicates (Block ?b) (Region ?r) (Pose ?b ?p) (Conf ?q) (Kin ?b ?p ?q) (AtPose ?b ?p)
    (AtConf ?q) (HandEmpty) (Holding ?b) (CanMove) (Contained ?b ?p ?r) (Motion ?q1 ?t ?q2)
    (In ?b ?r) (Placed ?b) (Before ?b1 ?b2))
  (:action move :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))))
  (:action pick :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (AtPose ?b ?p) (HandEmpty) (AtConf ?q)
                       (forall (?b1) (imply (Before ?b1 ?b) (Placed ?b1))))
    :effect (and (Holding ?b) (CanMove) (not (AtPose ?b ?p)) (not (HandEmpty))))
  (:action place :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q) (Holding ?b) (AtConf ?q))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove) (Placed ?b) (not (Holding ?b))))
  (:derived (In ?b ?r) (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p)))))
"""

TIGHT_STREAMS = """
(define (stream tight)
  (:stream sample-pose :inputs (?b ?r) :domain (and (Block ?b) (Region ?r))
    :outputs (?p) :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))
  (:stream ik :inputs (?b ?p) :domain (Pose ?b ?p) :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?p ?q)))
  (:stream motion :inputs (?q1 ?q2) :domain (and (Conf ?q1) (Conf ?q2)) :fluents (AtPose)
    :outputs (?t) :certified (Motion ?q1 ?t ?q2)))
"""


def test_a_fluent_failure_draws_again_the_sampler_of_what_stands_in_the_way() -> None:
    """Blocks of width 2 in the region [0, 4]; a is placed first, the first time at 2.0 (the
    middle); b's only pose there is 3.0, so the motion that brings b there fails because of
    where a stands. The sampler of a's pose is not upstream of that motion by its inputs, only
    by its context: drawing it again (a at 1.0) saves the plan within the same evaluation."""
    drawn: list[str] = []

    def pose(block: str, region: tuple[float, float]):
        drawn.append(block)
        yield from ((2.0,), (1.0,), (0.0,)) if block == "a" else ((3.0,),)

    def ik(block: str, p: float) -> tuple[tuple[str, float]]:
        return ((block, p),)  # above the block's pose

    def motion(q1: Any, q2: Any, fluents: list[tuple[Any, ...]]) -> tuple[Any] | None:
        if isinstance(q2, tuple):  # bringing block q2[0] above pose q2[1]
            on_table = [(f[1], f[2]) for f in fluents if f[0] == "atpose"]
            if any(b != q2[0] and abs(p - q2[1]) < 2.0 for b, p in on_table):
                return None
        return ((q1, q2),)

    problem = Problem.create(
        parse_domain(TIGHT_DOMAIN),
        parse_streams(TIGHT_STREAMS),
        init=[
            ("Block", "a"),
            ("Block", "b"),
            ("Region", "tight"),
            ("Before", "a", "b"),
            ("Pose", "a", "pa"),
            ("AtPose", "a", "pa"),
            ("Pose", "b", "pb"),
            ("AtPose", "b", "pb"),
            ("Conf", "home"),
            ("AtConf", "home"),
            ("HandEmpty",),
            ("CanMove",),
        ],
        goal=[("In", "a", "tight"), ("In", "b", "tight"), ("HandEmpty",)],
        objects={"tight": (0.0, 4.0), "pa": -10.0, "pb": -20.0, "home": "home"},
        implementations={
            "sample-pose": sampler(pose),
            "ik": function(ik),
            "motion": function(motion),
        },
    )
    result = solve(problem, PlannerConfig(defer=False, max_time=60))
    assert result.status is PlanStatus.SOLVED, result.message
    plan = result.plan
    assert plan is not None
    places = {s.args[0]: plan.objects[s.args[1]] for s in plan.steps if s.action == "place"}
    assert places == {"a": 1.0, "b": 3.0}
    # one evaluation (the second iteration only checks the plan with the real values)
    assert result.stats.iterations == 2
