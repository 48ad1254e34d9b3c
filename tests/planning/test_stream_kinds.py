"""``:predicate`` and ``:rule`` declarations planned with PDDLStream's semantics.

A 1-D table: blocks sit at poses; moving a block needs a pose that collides with no block at its
pose now (an external predicate, used only negated, through a derived predicate), and a
configuration that reaches it (IK; a rule says that whatever IK certifies is a configuration)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from llmpas.language.bindings import cost, sampler
from llmpas.language.domain import parse_domain
from llmpas.language.language_errors import BindingError
from llmpas.language.logic import Atom, FuncTerm
from llmpas.language.problem import Problem
from llmpas.language.semantics import Semantics, replay
from llmpas.language.streams import parse_streams
from llmpas.planning import PlannerConfig, PlanStatus, solve
from llmpas.planning.compile import function_values
from llmpas.planning.result import Plan, PlanStep

ALGORITHMS = ("focused", "skeletons", "incremental")

DOMAIN = """
(define (domain table1d)
  (:requirements :strips :derived-predicates)
  (:predicates (Block ?b) (Pose ?p) (Conf ?q) (Kin ?q ?p) (AtPose ?b ?p) (Goal ?p)
               (Collide ?p1 ?p2) (Unsafe ?p) (Placed ?b) (Touching ?b1 ?b2) (Pushed ?b))
  (:derived (Unsafe ?p)
    (exists (?b2 ?p2) (and (AtPose ?b2 ?p2) (Collide ?p ?p2))))
  (:action move
    :parameters (?b ?p1 ?p2 ?q)
    :precondition (and (Block ?b) (AtPose ?b ?p1) (Goal ?p2) (Kin ?q ?p2) (Conf ?q)
                       (not (Unsafe ?p2)))
    :effect (and (AtPose ?b ?p2) (not (AtPose ?b ?p1)) (Placed ?b)))
  (:action push
    :parameters (?b1 ?p1 ?b2 ?p2)
    :precondition (and (AtPose ?b1 ?p1) (AtPose ?b2 ?p2) (Collide ?p1 ?p2))
    :effect (Pushed ?b2)))
"""

STREAMS = """
(define (stream table1d)
  (:rule :inputs (?q ?p) :domain (Kin ?q ?p) :certified (Conf ?q))
  (:stream ik :inputs (?p) :domain (Pose ?p) :outputs (?q) :certified (Kin ?q ?p))
  (:predicate (Collide ?p1 ?p2) (and (Pose ?p1) (Pose ?p2)))
)
"""


def collide(p1: float, p2: float) -> bool:
    return abs(p1 - p2) < 1.0


def table(
    goal: list[tuple[Any, ...]],
    calls: list[tuple[float, float]],
    extra: list[tuple[Any, ...]] | None = None,
    ik_fails: float | None = None,
) -> Problem:
    def counted(p1: float, p2: float) -> bool:
        calls.append((p1, p2))
        return collide(p1, p2)

    def ik(p: float) -> Iterator[tuple[float]]:
        if p != ik_fails:
            yield (p + 0.25,)

    init: list[tuple[Any, ...]] = []
    for b, x in (("a", 0.0), ("b", 5.0), ("c", 5.5)):
        init += [("Block", b), ("Pose", x), ("AtPose", b, x)]
    # goal poses: 5.2 collides with b, 9.0 is free
    init += [("Pose", 5.2), ("Goal", 5.2), ("Pose", 9.0), ("Goal", 9.0)] + (extra or [])
    return Problem.create(
        parse_domain(DOMAIN),
        parse_streams(STREAMS),
        init=init,
        goal=goal,
        implementations={"ik": sampler(ik), "Collide": counted},
    )


def rebound(problem: Problem, **implementations: Any) -> Problem:
    """The same problem with other stream implementations."""
    return Problem.create(
        problem.domain,
        problem.streams,
        init=problem.init,
        goal=problem.goal,
        objects=dict(problem.objects),
        implementations=implementations,
    )


def one_step(problem: Problem, algorithm: str) -> tuple[Plan, PlanStep]:
    """Solve; the plan and its only step."""
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))  # type: ignore[arg-type]
    assert result.status is PlanStatus.SOLVED, result.message
    assert result.plan is not None
    (step,) = result.plan.steps
    return result.plan, step


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_used_negated_is_assumed_false_then_checked(algorithm: str) -> None:
    calls: list[tuple[float, float]] = []
    plan, step = one_step(table([("Placed", "a")], calls), algorithm)
    # the colliding goal pose was refused once the predicate was evaluated
    assert plan.objects[step.args[2]] == 9.0
    assert calls, "the external predicate was never evaluated"


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_used_positively_holds_only_where_it_is_true(algorithm: str) -> None:
    calls: list[tuple[float, float]] = []
    problem = table([("Pushed", "c")], calls)
    plan, step = one_step(problem, algorithm)
    # the plan lists (Collide ...) where the predicate said True: it replays on the domain as is
    sem = Semantics(problem.domain, dict.fromkeys(plan.objects, "object"))
    r = replay(sem, set(problem.init) | plan.certified, [(step.action, step.args)], problem.goal)
    assert r.valid, r.message
    # b (at 5.0) and c itself (at 5.5) collide with c's pose; a (at 0.0) does not
    assert step.action == "push" and step.args[0] in ("b", "c") and step.args[2] == "c"
    assert calls  # positive uses need the predicate evaluated on real poses


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_that_is_never_true_makes_positive_uses_unsolvable(
    algorithm: str,
) -> None:
    problem = rebound(table([("Pushed", "c")], []), ik=lambda p: (p,), collide=lambda a, b: False)
    result = solve(problem, PlannerConfig(algorithm=algorithm, max_time=60))
    assert result.status is PlanStatus.UNSOLVABLE, result.message


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_rule_certifies_from_init_facts_and_stream_outputs(algorithm: str) -> None:
    # IK has no solution for 9.0, but init gives one: only the rule makes it a configuration
    plan, step = one_step(
        table([("Placed", "a")], [], [("Kin", 9.75, 9.0)], ik_fails=9.0), algorithm
    )
    assert [plan.objects[a] for a in step.args[1:]] == [0.0, 9.0, 9.75]


def test_predicate_implementation_must_return_a_bool() -> None:
    problem = rebound(table([("Placed", "a")], []), ik=lambda p: (p,), collide=lambda a, b: "yes")
    result = solve(problem, PlannerConfig(max_time=60))
    assert result.status is PlanStatus.ERROR
    assert "predicate 'collide' returned str, not bool" in result.message


# ------------------------------------------------------------------------ per-stream options


def test_p_success_zero_streams_are_never_assumed_but_evaluated_on_real_inputs() -> None:
    asked: dict[str, list[float]] = {"lazy": [], "never-assumed": []}

    def ik_for(mode: str) -> Any:
        def ik(p: float) -> Iterator[tuple[float]]:
            asked[mode].append(p)
            yield (p + 0.25,)

        return ik

    for mode, info in (("lazy", {}), ("never-assumed", {"p_success": 0.0})):
        ik = sampler(ik_for(mode), **info)
        problem = rebound(table([("Placed", "a")], []), ik=ik, collide=collide)
        result = solve(problem, PlannerConfig(max_time=60))
        assert result.status is PlanStatus.SOLVED, result.message
    # the focused planner asks IK only for the goal pose its plan uses; a stream never assumed
    # is asked for every real pose (5 here) before the first search
    assert sorted(set(asked["never-assumed"])) == [0.0, 5.0, 5.2, 5.5, 9.0]
    assert len(set(asked["lazy"])) < 5


def test_p_success_zero_and_deferred_contradict() -> None:
    with pytest.raises(ValueError, match="p_success must be > 0"):
        sampler(lambda p: iter(()), deferred=True, p_success=0.0)


def test_opt_fn_gives_a_cost_its_optimistic_value() -> None:
    domain = parse_domain(
        "(define (domain d) (:predicates (Conf ?q)) (:functions (Dist ?a ?b))"
        " (:action go :parameters (?a ?b) :precondition (and (Conf ?a) (Conf ?b))"
        " :effect (increase (total-cost) (Dist ?a ?b))))"
    )
    spec = parse_streams(
        "(define (stream s) (:stream q :outputs (?q) :certified (Conf ?q))"
        " (:function (Dist ?a ?b) (and (Conf ?a) (Conf ?b))))"
    )
    seen: list[tuple[Any, ...]] = []

    def optimistic(a: Any, b: Any) -> float:
        seen.append((a, b))
        return 0.5 if a is None or b is None else 99.0

    problem = Problem.create(
        domain,
        spec,
        init=[("Conf", 2.0)],
        goal=[("Conf", 2.0)],
        implementations={
            "q": lambda: (1.0,),
            "dist": cost(lambda a, b: abs(a - b), opt_fn=optimistic),
        },
    )
    (real,) = problem.objects
    facts = set(problem.init) | {Atom("conf", ("#o1",))}
    values = function_values(problem, facts, {}, lambda n: problem.objects.get(n, n))
    assert values[FuncTerm("dist", (real, real))] == 0.0  # computed: both inputs are real
    assert values[FuncTerm("dist", (real, "#o1"))] == 0.5  # optimistic: one is not computed
    assert values[FuncTerm("dist", ("#o1", "#o1"))] == 0.5
    assert (2.0, None) in seen and (None, None) in seen


def test_opt_fn_is_for_functions_only() -> None:
    with pytest.raises(BindingError, match="opt_fn is for ':function' costs only"):
        rebound(table([], []), ik=sampler(lambda p: iter(()), opt_fn=len), collide=collide)


@pytest.mark.parametrize("algorithm", ALGORITHMS)
def test_external_predicate_in_the_goal_is_checked_before_the_plan_is_returned(
    algorithm: str,
) -> None:
    domain = parse_domain(
        "(define (domain g) (:predicates (Obj ?o) (Pose ?p) (At ?o ?p) (Bad ?o ?p))"
        " (:action go :parameters (?o ?p) :precondition (and (Obj ?o) (Pose ?p))"
        " :effect (At ?o ?p)))"
    )
    streams = parse_streams("(define (stream g) (:predicate (Bad ?o ?p) (and (Obj ?o) (Pose ?p))))")
    problem = Problem.create(
        domain,
        streams,
        init=[("Obj", "a"), ("Pose", "p1"), ("Pose", "p2")],
        goal="(exists (?p) (and (At a ?p) (not (Bad a ?p))))",
        implementations={"bad": lambda o, p: p == "p1"},
    )
    _, step = one_step(problem, algorithm)
    assert step.args == ("a", "p2")
