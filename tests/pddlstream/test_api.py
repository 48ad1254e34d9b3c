"""The wrappers, values, options and refusals of ``llmpas.pddlstream``."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from llmpas.errors import InputError
from llmpas.language.bindings import Kind
from llmpas.pddlstream import (
    And,
    Equal,
    Exists,
    FunctionInfo,
    Minimize,
    Not,
    PDDLProblem,
    StreamInfo,
    from_fn,
    from_gen_fn,
    from_list_fn,
    from_sampler,
    from_test,
    solve,
    translate,
)
from llmpas.pddlstream.compat import PlanConstraints
from llmpas.pddlstream.solving import SolveContext
from llmpas.pddlstream.translate import Unsupported
from llmpas.pddlstream.wrappers import Notes, from_list_gen_fn

DOMAIN = """
(define (domain d)
  (:requirements :strips)
  (:predicates (Obj ?o) (Good ?o ?v) (Done ?o))
  (:action finish :parameters (?o ?v)
    :precondition (and (Obj ?o) (Good ?o ?v))
    :effect (Done ?o)))
"""
STREAMS = """
(define (stream d)
  (:stream make :inputs (?o) :domain (Obj ?o) :outputs (?v) :certified (Good ?o ?v)))
"""


def outputs(procedure, *inputs):
    impl = procedure.implementation()
    if impl.kind is Kind.FUNCTION:
        return [impl.fn(*inputs)]
    if impl.kind is Kind.TEST:
        return [impl.fn(*inputs)]
    return list(impl.fn(*inputs))


def test_wrappers_answer_in_llmpas_shape() -> None:
    assert outputs(from_fn(lambda x: (x + 1,)), 1) == [(2,)]
    assert outputs(from_list_fn(lambda x: [(x,), (x * 2,)]), 3) == [(3,), (6,)]
    assert outputs(from_gen_fn(lambda x: iter([(x,), None, (x + 1,)])), 1) == [(1,), None, (2,)]
    assert outputs(from_list_gen_fn(lambda x: iter([[(x,)], [], [(x,), (x,)]])), 5) == [
        (5,),
        None,
        (5,),
        (5,),
    ]
    assert outputs(from_test(lambda x: [x]), 0) == [True]  # truthy values are True
    assert outputs(from_test(lambda x: np.bool_(False)), 0) == [False]
    it = from_sampler(lambda x: (x,)).implementation().fn(7)
    assert [next(it) for _ in range(3)] == [(7,)] * 3


def test_expressions_are_pddlstream_tuples() -> None:
    assert And(("A",)) == ("A",)
    assert And(("A",), ("B",)) == ("and", ("A",), ("B",))
    assert Equal(("Cost",), 1) == ("=", ("Cost",), 1)
    assert Exists(["?x"], ("P", "?x")) == ("exists", ("?x",), ("P", "?x"))
    assert Not(("P",)) == ("not", ("P",))


class Thing:  # unhashable-by-value objects are compared by identity
    __hash__ = None  # type: ignore[assignment]


def problem(init, goal, stream_map=None):
    impl = stream_map if stream_map is not None else {"make": from_fn(lambda o: (o,))}
    return PDDLProblem(DOMAIN, {}, STREAMS, impl, init, goal)


def test_values_round_trip_by_identity_and_content() -> None:
    a, b = Thing(), Thing()
    arr = np.array([1.0, 2.0])
    plan, cost, cert = solve(
        problem(
            [("Obj", a), ("Obj", b), ("Obj", arr)],
            And(("Done", a), ("Done", b), ("Done", np.array([1.0, 2.0]))),
        ),
        max_time=30,
    )
    assert plan is not None and cost == len(plan) == 3
    done = {id(x.args[0]) for x in plan}
    assert done == {id(a), id(b), id(arr)}  # the objects given, not copies
    assert all(x.args[0] is x.args[1] for x in plan)  # the stream's output is its input
    assert ("Obj", a) in cert.all_facts


def test_strings_keep_their_spelling() -> None:
    plan, _, _ = solve(problem([("Obj", "Box-A")], ("Done", "Box-A")), max_time=30)
    assert plan == [("finish", ("Box-A", "Box-A"))]


def test_no_plan_is_none_and_inf() -> None:
    plan, cost, _ = solve(problem([("Obj", "x")], ("Done", "y")), max_time=30)
    assert plan is None and cost == float("inf")


def test_ignored_options_are_said_once(caplog) -> None:
    ctx = SolveContext(notes=Notes())
    info = {"make": StreamInfo(negate=True, p_success=0.5)}
    with caplog.at_level(logging.WARNING):
        for _ in range(2):
            solve(
                problem([("Obj", "x")], ("Done", "x")), stream_info=info, context=ctx, max_time=30
            )
    said = [r.getMessage() for r in caplog.records if "negate" in r.getMessage()]
    assert len(said) == 1 and "ignored" in said[0]


def test_options_map_to_llmpas_info() -> None:
    tr = translate(
        problem([("Obj", "x")], ("Done", "x")),
        {"make": StreamInfo(eager=True, overhead=3)},
    )
    info = tr.problem.bound_streams["make"].info
    assert info.eager and info.p_success == 1 and info.overhead == 3  # still assumed
    tr = translate(
        problem([("Obj", "x")], ("Done", "x")), {"make": StreamInfo(eager=True, p_success=0)}
    )
    assert tr.problem.bound_streams["make"].info.never_assumed
    assert FunctionInfo(lambda *a: 2).options[0][0] == "opt_fn"  # positional, as PDDLStream


@pytest.mark.parametrize(
    ("kwargs", "pds", "words"),
    [
        ({"algorithm": "anytime-magic"}, None, "algorithm 'anytime-magic' does not exist"),
        ({"constraints": PlanConstraints(skeletons=[[]])}, None, "skeletons"),
        ({}, problem([("Obj", "x")], Minimize(("Total",))), "'minimize'"),
        (
            {},
            PDDLProblem(
                DOMAIN, {}, "(define (stream s) (:optimizer gurobi))", {}, [], ("Done", "x")
            ),
            "':optimizer' is not supported",
        ),
        (
            {},
            PDDLProblem(
                "(define (domain t) (:requirements :durative-actions))",
                {},
                None,
                {},
                [],
                ("Done", "x"),
            ),
            "temporal planning",
        ),
    ],
)
def test_unsupported_constructs_are_one_line(kwargs, pds, words) -> None:
    pds = pds or problem([("Obj", "x")], ("Done", "x"))
    with pytest.raises(InputError) as e:
        solve(pds, max_time=30, **kwargs)
    assert words in str(e.value) and "\n" not in str(e.value)
    if "algorithm" in kwargs or "constraints" in kwargs:
        assert isinstance(e.value, Unsupported)


def test_numeric_init_and_unknown_goal_objects() -> None:
    with pytest.raises(InputError, match=r"init\[0\].*not a number"):
        translate(problem([Equal(("Cost",), "one")], ("Done", "x")))
    with pytest.raises(InputError, match="not bound by an Exists"):
        translate(problem([("Obj", "x")], ("Done", "?free")))


def test_solve_from_pddl_plans_a_plain_pddl_problem() -> None:
    from pathlib import Path

    from llmpas.language.domain import read_domain
    from llmpas.language.problem import read_problem
    from llmpas.language.semantics import Semantics, replay
    from llmpas.pddlstream import read, solve_from_pddl

    folder = Path(__file__).parents[2] / "src" / "llmpas" / "examples" / "blocksworld"
    plan, cost = solve_from_pddl(read(folder / "domain.pddl"), read(folder / "problem.pddl"))
    assert plan is not None and cost == len(plan)
    problem = read_problem(read_domain(folder / "domain.pddl"), folder / "problem.pddl")
    sem = Semantics(problem.domain, problem.object_types)
    steps = [(a.name, tuple(str(x).lower() for x in a.args)) for a in plan]
    assert replay(sem, problem.init, steps, problem.goal).valid


def test_fluents_reach_the_stream_as_value_tuples() -> None:
    seen: list = []
    pos = np.array([1.0, 2.0])

    def make(o, fluents=()):
        seen.extend(fluents)
        return (o,)

    streams = STREAMS.replace(":outputs (?v)", ":fluents (Obj) :outputs (?v)")
    pds = PDDLProblem(DOMAIN, {}, streams, {"make": from_fn(make)}, [("Obj", pos)], ("Done", pos))
    plan, _, _ = solve(pds, max_time=30)
    assert plan is not None
    assert seen and all(f[0] == "obj" and f[1] is pos for f in seen)


def test_wild_outputs_of_a_list_fn_are_taken() -> None:
    """Its values are outputs (its facts: tests/pddlstream/test_wild.py)."""
    from llmpas.pddlstream.wrappers import WildOutput

    pds = problem(
        [("Obj", "x")], ("Done", "x"), {"make": from_list_fn(lambda o: WildOutput(values=[(o,)]))}
    )
    plan, _, _ = solve(pds, max_time=30)
    assert plan == [("finish", ("x", "x"))]


def test_init_values_of_undeclared_functions_are_ignored_once(caplog) -> None:
    """PDDLStream accepts ``Equal(('Cost',), 1)`` in init when the domain declares no ``Cost``
    (its continuous_tamp/idtmp example): said to be ignored, and the task plans."""
    pds = problem([("Obj", "x"), Equal(("Cost",), 1), Equal(("Cost",), 1)], ("Done", "x"))
    with caplog.at_level(logging.WARNING):
        plan, cost, _ = solve(pds, max_time=30)
    assert plan is not None and cost == 1
    said = [r.getMessage() for r in caplog.records if "(= (cost ...) ...)" in r.getMessage()]
    assert len(said) == 1 and "declares no such function" in said[0]


def test_read_pddl_reads_a_file_next_to_a_script(tmp_path) -> None:
    from llmpas.pddlstream import utils

    (tmp_path / "domain.pddl").write_text("(define (domain d))", encoding="utf-8")
    script = tmp_path / "run.py"
    # PDDLStream's read_pddl(this_file, pddl_filename), as cashpoint/run.py calls it
    assert utils.read_pddl(str(script), "domain.pddl") == "(define (domain d))"


POINTS_DOMAIN = """
(define (domain points)
  (:requirements :strips)
  (:predicates (Point ?p) (Next ?p ?q) (At ?p))
  (:action step :parameters (?p ?q)
    :precondition (and (At ?p) (Next ?p ?q))
    :effect (and (At ?q) (not (At ?p)))))
"""
POINTS_STREAMS = """
(define (stream points)
  (:stream successor :inputs (?p) :domain (Point ?p) :outputs (?q)
    :certified (and (Point ?q) (Next ?p ?q))))
"""


@pytest.mark.parametrize("goal_value", [3, 4])
def test_a_stream_output_equal_to_an_init_value_is_that_object(goal_value) -> None:
    """As in PDDLStream: the goal names an init value (3 or 4); the stream reaches it from 2
    (incremental: a focused search has no optimistic plan through placeholders, as in
    PDDLStream's focused algorithm, where an optimistic object is never an init object)."""
    init = [("Point", 2), ("At", 2), ("Point", 3)]
    stream_map = {"successor": from_fn(lambda p: (p + 1,))}
    plan, cost, cert = solve(
        PDDLProblem(POINTS_DOMAIN, {}, POINTS_STREAMS, stream_map, init, ("At", goal_value)),
        algorithm="incremental",
        max_time=30,
    )
    assert plan is not None and [a.name for a in plan] == ["step"] * (goal_value - 2)
    assert cost == goal_value - 2
    assert plan[-1].args[1] == goal_value
    # one object for 3: the init's facts and the stream's are about the same one
    assert ("next", 2, 3) in cert.all_facts and ("Point", 3) in cert.all_facts


def test_placeholders_are_shared_only_for_shared_debug_streams() -> None:
    """One placeholder per stream output when every stream gives one value per stream and
    output (SHARED_DEBUG), as PDDLStream's shared optimistic objects; one per instance else."""
    from llmpas.pddlstream.solving import _shared_values

    def problem(stream_map: object) -> PDDLProblem:
        return PDDLProblem("", {}, "", stream_map, [], ())

    assert _shared_values(problem("shared_debug")) and _shared_values(problem("SHARED_DEBUG"))
    assert not _shared_values(problem("debug")) and not _shared_values(problem({}))
