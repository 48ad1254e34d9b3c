"""A goal that contradicts the domain's invariants (:mod:`llmpas.planning.invariants`) in the
loop: refused by the checks before any planner call, and never built by joining a recovery goal
with the task or with goals kept from earlier rounds."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.language.domain import read_domain
from llmpas.language.logic import And, Atom, Not
from llmpas.language.streams import read_streams
from llmpas.planning.invariants import Invariants
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus
from llmpas.system.goal_checks import GoalChecker
from llmpas.system.recovery import Stages, kept_goal
from tests.system.tiny import SEM, Facts, memory

KITCHEN = Path(__file__).parents[2] / "src" / "llmpas" / "worlds" / "kitchen"
FACTS = frozenset(
    {
        Atom("supported", ("apple", "p1", "table1")),
        Atom("atpose", ("apple", "p1")),
        Atom("supported", ("apple", "p2", "fridge")),
    }
)


def a(text: str) -> Atom:
    words = text.strip("()").split()
    return Atom(words[0].lower(), tuple(words[1:]))


@pytest.fixture(scope="module")
def kitchen() -> Invariants:
    return Invariants.of(
        read_domain(KITCHEN / "domain.pddl"), read_streams(KITCHEN / "stream.pddl")
    )


class NoPlanner:
    """A planner that must not be called."""

    calls = 0

    def __call__(self, goal: object) -> object:
        self.calls += 1
        raise AssertionError(f"planned {goal}")


def test_the_check_refuses_a_contradiction_before_any_planner_call(kitchen: Invariants) -> None:
    facts = Facts(set(FACTS))
    goal = And((a("(cooled apple)"),))
    planner = NoPlanner()
    check = GoalChecker(
        memory(facts, task=goal),
        planner,  # type: ignore[arg-type]
        lambda g: facts(),
        SEM,
        goal,
        contradiction=lambda goals: kitchen.contradiction(goals, FACTS),
    )
    out = check(GoalParse(GoalStatus.OK, (a("(on apple microwave)"), a("(on apple sink)")), ()))
    assert out.status is GoalStatus.UNREACHABLE and planner.calls == 0
    assert "cannot be achieved together" in out.errors[0]


def test_a_recovery_goal_replaces_the_task_literal_it_is_about(kitchen: Invariants) -> None:
    """Joined with the task and the goals kept from earlier rounds, a new goal replaces the
    literals it contradicts instead of conjoining two places."""
    task = And((a("(cooled apple)"), a("(on apple table1_left)")))
    kept = [a("(on apple microwave)"), Not(a("(on apple sink)"))]
    joined = kept_goal(task, kept, [a("(on apple table2_right)")], kitchen.conflicts(FACTS))
    assert str(joined) == ("(and (on apple table2_right) (cooled apple) (not (on apple sink)))")
    assert kitchen.contradiction([p for p in joined.parts], FACTS) == ""  # type: ignore[misc]


def test_a_goal_reached_replaces_the_kept_goal_it_contradicts(kitchen: Invariants) -> None:
    stages = Stages(kept=[a("(on apple microwave)"), a("(cooled mug)")])
    stages.reached([a("(on apple table2_right)")], kitchen.conflicts(FACTS))
    assert [str(k) for k in stages.kept] == ["(cooled mug)", "(on apple table2_right)"]
