"""Fluent streams with llmpas's native API, on stream and domain files: a grasp exists only
while no block is on the grasped one, so the stream must see the state where the grasp is used,
not the initial one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from llmpas.language.bindings import function
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
        covered = any(a.predicate == "on" and a.args[1] == block for a in fluents)
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
    # b's grasp was refused while a was on b, then given where a is on the table
    assert ("b", [Atom("on", ("a", "b")), Atom("on", ("b", "table"))]) in calls
    assert ("b", [Atom("on", ("a", "table")), Atom("on", ("b", "table"))]) in calls
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
