"""The replay check finds plans that do not hold, independently of the planner's claims."""

from __future__ import annotations

import dataclasses

import numpy as np

from llmpas.pddlstream.solution_check import validate


def solved(load_script):
    loaded = load_script("tamp2d")
    s = loaded.module
    s.solve(s.make_problem(), stream_info=s.STREAM_INFO, max_time=60)
    (attempt,) = loaded.attempts
    assert validate(attempt).valid
    return s, attempt


def with_steps(attempt, steps):
    plan = dataclasses.replace(attempt.result.plan, steps=tuple(steps))
    return dataclasses.replace(
        attempt, result=dataclasses.replace(attempt.result, plan=plan, improvements=())
    )


def test_a_step_out_of_place_is_found(load_script) -> None:
    _, attempt = solved(load_script)
    steps = list(attempt.result.plan.steps)
    v = validate(with_steps(attempt, steps[1:]))
    assert not v.valid and "step 1" in v.message


def test_a_missing_last_step_misses_the_goal(load_script) -> None:
    _, attempt = solved(load_script)
    v = validate(with_steps(attempt, list(attempt.result.plan.steps)[:-1]))
    assert not v.valid


def test_tests_are_recomputed_not_trusted(load_script) -> None:
    _, attempt = solved(load_script)
    problem = attempt.translation.problem
    # the planner's claims of CFree are not used: with the last place's pose moved onto where
    # the other block was placed before, the recomputed test fails and the place is unsafe
    places = [st for st in attempt.result.plan.steps if st.action == "place"]
    last = places[-1]
    other = [p for p in places[:-1] if p.args[0] != last.args[0]][-1]
    values = {**problem.objects, **attempt.result.plan.objects}
    moved = dict(attempt.result.plan.objects)
    moved[last.args[1]] = values[other.args[1]] + np.array([0.2, 0.0])
    plan = dataclasses.replace(attempt.result.plan, objects=moved)
    bad = dataclasses.replace(
        attempt, result=dataclasses.replace(attempt.result, plan=plan, improvements=())
    )
    assert problem.objects  # the problem is unchanged
    v = validate(bad)
    assert not v.valid, "a place on top of another block replayed"


def test_a_wrong_reported_cost_is_found(load_script) -> None:
    _, attempt = solved(load_script)
    wrong = attempt.solution._replace(cost=attempt.solution.cost + 5)
    v = validate(dataclasses.replace(attempt, solution=wrong))
    assert not v.valid and "cost" in v.message
