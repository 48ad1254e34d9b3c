"""The checks of the LLM's goals (:class:`llmpas.system.goal_checks.GoalChecker`), without a world:
a tiny search memory, a belief of a few facts and a planner that answers from a table."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import pytest

from llmpas.language.logic import And, Formula, Not
from llmpas.planning import PlanResult, PlanStatus
from llmpas.planning.result import Plan, PlanStats
from llmpas.reasoning.assists import Assists
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Literal
from llmpas.reasoning.methods import Check
from llmpas.system.goal_checks import GoalChecker
from tests.system.tiny import SEM, Facts, atom, failed_look, memory


class Planner:
    """Solves the goals listed (by text), times out on those listed so; counts its calls."""

    def __init__(self, solvable: Iterable[str] = (), timeouts: Iterable[str] = ()) -> None:
        self.solvable = set(solvable)
        self.timeouts = set(timeouts)
        self.calls: list[str] = []

    def __call__(self, goal: Formula) -> PlanResult:
        text = str(goal)
        self.calls.append(text)
        if text in self.solvable:
            return PlanResult(PlanStatus.SOLVED, Plan((), 0.0), PlanStats())
        if text in self.timeouts:
            return PlanResult(PlanStatus.TIMEOUT, None, PlanStats(), "time limit")
        return PlanResult(PlanStatus.UNSOLVABLE, None, PlanStats(), "no plan")


def checker(
    planner: Planner,
    facts: Facts | None = None,
    task: str = "(holding cup)",
    tried: Callable[[], Sequence[frozenset[str]]] = tuple,
    assists: Assists | None = None,
    searched: tuple[str, ...] = (),
) -> GoalChecker:
    belief = facts or Facts()
    goal = And((atom(task),))
    m = memory(belief, task=goal)
    if searched:
        m.remember(failed_look("cup", searched))
    return GoalChecker(m, planner, lambda g: belief(), SEM, goal, tried, assists or Assists())


def parse(*goals: str) -> GoalParse:
    lits: tuple[Literal, ...] = tuple(
        Not(atom(g[5:-1])) if g.startswith("(not ") else atom(g) for g in goals
    )
    return GoalParse(GoalStatus.OK, lits, ())


def shown(goals: Iterable[Literal]) -> list[str]:
    return [str(g) for g in goals]


def test_a_goal_checker_is_reasonings_check() -> None:
    check: Check = checker(Planner())
    out = check(parse("(clean plate)"))
    assert out.status is GoalStatus.UNREACHABLE  # nothing is solvable for this planner


def test_goals_already_true_are_dropped_and_all_true_is_rejected() -> None:
    facts = Facts({atom("(clean cup)"), atom("(on cup t1)")})
    plan = Planner({"(and (holding cup))"})
    out = checker(plan, facts)(parse("(clean cup)", "(holding cup)"))
    assert out.ok and shown(out.goals) == ["(holding cup)"]
    assert "dropped (clean cup): it already holds" in out.notes
    out = checker(plan, facts)(parse("(clean cup)"))
    assert out.status is GoalStatus.ALREADY_TRUE and "already holds" in out.errors[0]


def test_a_search_made_in_vain_is_rejected_naming_the_places_left() -> None:
    out = checker(Planner(), searched=("t1",))(parse("(on cup t1)"))
    assert out.status is GoalStatus.REPEATED
    assert out.errors == (
        "(scanned t1): t1 was already searched for cup from several positions without finding "
        "it; look elsewhere (not searched yet: t2, t3)",
    )
    assert shown(out.rejected) == ["(on cup t1)"]  # the literal as the LLM wrote it


def test_a_lost_objects_location_is_read_as_a_search_but_the_tasks_own_literal_is_not() -> None:
    plan = Planner({"(and (scanned t2))", "(and (on cup t2))"})
    out = checker(plan)(parse("(on cup t2)"))
    assert out.ok and shown(out.goals) == ["(scanned t2)"]
    assert "read (on cup t2) as (scanned t2): where cup is, is unknown" in out.notes
    out = checker(plan, task="(on cup t2)")(parse("(on cup t2)"))
    assert out.ok and shown(out.goals) == ["(on cup t2)"]


def test_unreachable_goals_are_dropped_or_rejected_with_feedback() -> None:
    plan = Planner({"(and (clean plate))"})
    out = checker(plan)(parse("(clean plate)", "(holding cup)"))
    assert out.ok and shown(out.goals) == ["(clean plate)"]
    assert "dropped (holding cup): unreachable" in out.notes
    out = checker(plan)(parse("(holding cup)"))
    assert out.status is GoalStatus.UNREACHABLE
    assert "cup: location unknown; find it first with a goal (scanned PLACE)" in out.errors[0]
    assert shown(out.rejected) == ["(holding cup)"]


def test_goals_reachable_one_by_one_but_not_together_are_rejected() -> None:
    plan = Planner({"(and (clean plate))", "(and (clean cup))"})
    out = checker(plan)(parse("(clean plate)", "(clean cup)"))
    assert out.status is GoalStatus.UNREACHABLE
    assert out.errors == ("(clean plate) (clean cup): cannot be achieved together",)


def test_a_planner_that_times_out_gives_no_verdict() -> None:
    out = checker(Planner(timeouts={"(and (clean plate))"}))(parse("(clean plate)"))
    assert out.status is GoalStatus.UNREACHABLE
    assert out.errors == ("(clean plate): not judged: time limit",)


def test_goals_tried_before_in_vain_are_rejected() -> None:
    plan = Planner({"(and (clean plate))"})
    tried = [frozenset({"(clean plate)"})]
    out = checker(plan, tried=lambda: tried)(parse("(clean plate)"))
    assert out.status is GoalStatus.REPEATED
    assert out.errors == ("(clean plate) was already tried and did not help",)
    assert checker(plan)(parse("(clean plate)")).ok  # not tried: taken


def test_one_answer_costs_at_most_one_plus_n_plus_one_planner_goals() -> None:
    plan = Planner({"(and (clean plate))", "(and (clean cup))", "(and (clean plate) (clean cup))"})
    out = checker(plan)(parse("(clean plate)", "(clean cup)", "(holding plate)"))
    assert out.ok and shown(out.goals) == ["(clean plate)", "(clean cup)"]
    assert len(set(plan.calls)) <= 1 + 3 + 1


@pytest.mark.parametrize("validation", [False, True])
def test_without_validation_only_the_search_rewrite_runs(validation: bool) -> None:
    out = checker(Planner(), assists=Assists(validation=validation))(parse("(on cup t2)"))
    assert shown(out.goals if out.ok else out.rejected) == (
        ["(scanned t2)"] if not validation else ["(on cup t2)"]
    )
    assert out.ok is not validation  # validated: (scanned t2) has no plan here
