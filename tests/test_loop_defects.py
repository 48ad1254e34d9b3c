"""The loop defects held-out tasks exposed (issue #31), each on a scenario of its own in
tests/data/loop/ (frozen-bread-cook, broken-mug, cube-in-bowl-lost, broken-cup-other) with a
scripted answer (a test double that knows nothing) or the labelled oracle (an upper bound), and
the makeable-literal test on a domain written here. Each failed before its fix."""

from __future__ import annotations

from pathlib import Path

from llmpas.experiments.suite import Verdict, judge, load_task
from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.language.domain import parse_domain
from llmpas.language.logic import And, Atom, Not
from llmpas.reasoning.goal_reading import GoalStatus
from llmpas.reasoning.truth_oracle import ORACLE
from llmpas.system.achievable import Makeable, certified
from llmpas.system.catalog import oracle_for
from llmpas.system.goal_checks import GoalChecker
from llmpas.worlds.api import RunOptions
from llmpas.worlds.household.household_plugin import WORLD
from tests.system.test_checks import Planner, parse
from tests.system.tiny import SEM, Facts, atom, memory
from tests.test_system import Scripted, clean_blackboard  # noqa: F401 (autouse)

DATA = Path(__file__).parent / "data" / "loop"
FROZEN = str(DATA / "frozen-bread-cook.toml")


def goal_prompts(llm: Scripted) -> list[str]:
    return [r.messages[-1].content for r in llm.requests if r.tag == "goals"]


# ------------------------------------------------- 1. a failed goal is recorded as tried


def test_goals_whose_execution_failed_are_tried_and_the_next_consultation_is_told() -> None:
    """The bread is frozen: "cooled, then cooked" is planned, and the cook fails again. The
    next consultation's prompt says so, and the answer is not taken again (before, only
    achieved goals counted as tried: the second prompt did not say it, and the answer was
    executed again, failing the same way)."""
    llm = Scripted("Goals: (and (cooled bread) (cooked bread))")
    result = run_loop(FROZEN, llm)
    assert not result.success
    prompts = goal_prompts(llm)
    assert len(prompts) == 2 and "could not be achieved" not in prompts[0]
    told = [ln for ln in prompts[1].splitlines() if "could not be achieved" in ln]
    assert told and "(cooked bread) (cooled bread)" in told[0] and "frozen" in told[0]
    second = [r.proposal for r in result.rounds if r.proposal][1]
    assert second is not None and not second.ok
    executed = [r.goal for r in result.rounds if r.episode is not None]
    assert executed.count("(and (cooked bread) (cooled bread))") == 1


# ------------------------------------------------- 2. no identical prompt twice in a run


def test_an_identical_request_is_never_sent_twice_in_one_run() -> None:
    """Cooling the bread does not thaw it: the cook fails again with the same anomaly, so the
    second consultation's first look is the first's, byte for byte. It is answered from the
    first (a fixed seed gives the same answer), not sent again."""
    llm = Scripted("Goals: (and (cooled bread))")
    result = run_loop(FROZEN, llm)
    consultations = [r.proposal for r in result.rounds if r.proposal]
    assert len(consultations) >= 2
    keys = [r.key() for r in llm.requests]
    assert len(keys) == len(set(keys)), [r.tag for r in llm.requests]
    looks = [e for p in consultations for e in p.exchanges if e.tag == "first-look"]
    assert len(looks) == len(consultations)  # every consultation still has its first look


# ------------------------------------------------- 3. only makeable literals


KITCHEN = parse_domain(
    """(define (domain kitchen-lite)
         (:requirements :strips :negative-preconditions :derived-predicates)
         (:predicates (shelf ?s) (oven ?o) (item ?i) (at ?i ?s) (baked ?i) (seen ?s)
                      (burnt ?i) (free ?s))
         (:derived (free ?s) (and (shelf ?s) (not (exists (?i) (at ?i ?s)))))
         (:action look :parameters (?s) :precondition (shelf ?s) :effect (seen ?s))
         (:action bake :parameters (?i ?o) :precondition (and (oven ?o) (item ?i))
                  :effect (and (baked ?i) (not (burnt ?i))))
         (:action move :parameters (?i ?a ?b)
                  :precondition (and (item ?i) (at ?i ?a) (shelf ?b))
                  :effect (and (at ?i ?b) (not (at ?i ?a)))))""",
    "kitchen-lite.pddl",
)
TYPES = frozenset({Atom("shelf", ("s1",)), Atom("oven", ("o1",)), Atom("item", ("bun",))})


def test_a_literal_no_action_makes_true_is_not_makeable() -> None:
    makeable = Makeable(KITCHEN, lambda literal: TYPES)
    assert makeable(Atom("seen", ("s1",)))
    assert not makeable(Atom("seen", ("o1",)))  # looking needs a shelf: the oven is none
    assert makeable(Atom("baked", ("bun",))) and not makeable(Not(Atom("baked", ("bun",))))
    assert makeable(Not(Atom("burnt", ("bun",)))) and not makeable(Atom("burnt", ("bun",)))
    assert makeable(Atom("free", ("s1",)))  # derived from a predicate actions change
    assert not makeable(Atom("shelf", ("o1",)))  # a type


def test_the_checker_rejects_an_unmakeable_goal_without_planning_it() -> None:
    """``(scanned t3)`` where no action looks at t3: rejected as unreachable, with the
    planner's feedback, and the planner is never asked (before: every such goal was planned,
    alone and with the others)."""
    planner = Planner(solvable=["(and (scanned t1))"])
    facts = Facts()
    goal = atom("(holding cup)")
    check = GoalChecker(
        memory(facts, task=And((goal,))),
        planner,
        lambda g: facts(),
        SEM,
        And((goal,)),
        makeable=lambda g: g != atom("(scanned t3)"),
    )
    out = check(parse("(scanned t3)"))
    assert out.status is GoalStatus.UNREACHABLE
    assert "no sequence of the robot's actions" in out.errors[0]
    assert planner.calls == []
    both = check(parse("(scanned t1)", "(scanned t3)"))
    assert both.ok and [str(g) for g in both.goals] == ["(scanned t1)"]
    assert all("t3" not in c for c in planner.calls)


def test_the_household_s_looks_at_the_sink_are_not_makeable() -> None:
    with WORLD.open(FROZEN, RunOptions()) as s:
        task = s.problem("(and (cooked bread))", 0)
        makeable = Makeable(s.domain, lambda g: s.problem(And((g,)), 0).init, certified(task))
        assert not makeable(atom("(scanned sink)")) and not makeable(atom("(scanned stove)"))
        assert makeable(atom("(scanned table2_left)")) and makeable(atom("(scanned fridge)"))
        assert makeable(atom("(cleaned bread)")) and not makeable(atom("(hot bread)"))


# ------------------------------------------------- 4. the oracle is an upper bound


def test_the_oracle_answers_legal_goals_for_an_object_in_a_bowl() -> None:
    """The cube is in the bowl on table2_right: the oracle answered ``(scanned bowl)``, which
    the vocabulary rejects (a look at a bowl is no goal), and the run ended "the LLM gave no
    usable goals". A look at the table the bowl stands on finds it."""
    result = run_loop(str(DATA / "cube-in-bowl-lost.toml"), ORACLE)
    assert result.success, result.message
    first = next(r.proposal for r in result.rounds if r.proposal)
    assert first is not None and [str(g) for g in first.goals] == ["(scanned table2_right)"]


def test_the_oracle_reads_the_task_s_intent_for_a_substitute() -> None:
    """The mug is broken and the intent says the plate will do: the oracle had no goal."""
    task = load_task(DATA / "broken-cup-other.toml")
    judged = judge(task, oracle_for("household"), LoopConfig())
    assert judged.verdict is Verdict.SUCCESS, judged.message


def test_the_oracle_s_failure_is_not_called_the_llm_s() -> None:
    """No intent, a broken mug: the oracle has no goal, and the run says it was the oracle."""
    result = run_loop(str(DATA / "broken-mug.toml"), ORACLE)
    assert not result.success
    assert "the oracle" in result.message and "LLM" not in result.message


# ------------------------------------------------- 5. restating the goal that just failed


def test_an_answer_restating_the_goal_that_just_failed_gets_that_feedback() -> None:
    """The cook of the frozen bread failed; "(cooked bread)" again would plan the same cook,
    and nothing the robot believes has changed: sent back saying so (before: planned and
    executed, failing the same way in every round)."""
    llm = Scripted("Goals: (and (cooked bread))")
    result = run_loop(FROZEN, llm)
    first = next(r.proposal for r in result.rounds if r.proposal)
    assert first is not None and first.parse.status is GoalStatus.REPEATED
    assert any("restates the goal that just failed" in e for e in first.parse.errors)
    repairs = [r for r in llm.requests if r.tag.startswith("repair")]
    assert repairs and "restates the goal that just failed" in repairs[0].messages[-1].content
    assert sum(r.episode is not None for r in result.rounds) == 1  # the cook failed once


def test_restating_the_task_is_taken_when_the_belief_now_explains_the_failure() -> None:
    """Replanning the task after the robot saw the cause still works (the replan row's case):
    the object-loss scenario's cube is seen elsewhere, and the task restated is accepted."""
    llm = Scripted("Goals: (and (on cube bowl))")
    result = run_loop(str(DATA / "searched-before.toml"), llm)
    first = next(r.proposal for r in result.rounds if r.proposal)
    assert first is not None
    assert not any("restates" in e for e in first.parse.errors)
