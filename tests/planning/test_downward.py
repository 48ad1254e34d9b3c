"""Tests for the Fast Downward wrapper (they run the real translator and search binary)."""

from __future__ import annotations

import contextlib
import os
import resource
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from llmpas.planning import downward
from llmpas.planning.downward import (
    LAZY_WASTAR_FF,
    ClassicalPlan,
    ClassicalStatus,
    DownwardConfig,
    FastDownward,
    PlannerNotFound,
    parse_plan,
)

BLOCKS_DOMAIN = """
(define (domain blocks)
 (:requirements :strips)
 (:predicates (on ?x ?y) (ontable ?x) (clear ?x) (handempty) (holding ?x))
 (:action pick-up :parameters (?x)
  :precondition (and (clear ?x) (ontable ?x) (handempty))
  :effect (and (not (ontable ?x)) (not (clear ?x)) (not (handempty)) (holding ?x)))
 (:action put-down :parameters (?x)
  :precondition (holding ?x)
  :effect (and (not (holding ?x)) (clear ?x) (handempty) (ontable ?x)))
 (:action stack :parameters (?x ?y)
  :precondition (and (holding ?x) (clear ?y))
  :effect (and (not (holding ?x)) (not (clear ?y)) (clear ?x) (handempty) (on ?x ?y)))
 (:action unstack :parameters (?x ?y)
  :precondition (and (on ?x ?y) (clear ?x) (handempty))
  :effect (and (holding ?x) (clear ?y) (not (clear ?x)) (not (handempty)) (not (on ?x ?y)))))
"""

# Sussman anomaly: C on A, B on the table; goal A on B on C. Shortest plan has 6 steps.
BLOCKS_PROBLEM = """
(define (problem sussman) (:domain blocks) (:objects A B C)
 (:init (ontable A) (ontable B) (on C A) (clear B) (clear C) (handempty))
 (:goal (and (on A B) (on B C))))
"""

# A box makes a room `blocked` (derived); moving needs (not (blocked ?to)).
ROOMS_DOMAIN = """
(define (domain rooms)
 (:requirements :typing :derived-predicates :negative-preconditions
  :existential-preconditions :action-costs)
 (:types room box)
 (:predicates (at ?r - room) (in ?b - box ?r - room) (adjacent ?a ?b - room)
  (blocked ?r - room))
 (:functions (total-cost) - number)
 (:derived (blocked ?r - room) (exists (?b - box) (in ?b ?r)))
 (:action move :parameters (?from ?to - room)
  :precondition (and (at ?from) (adjacent ?from ?to) (not (blocked ?to)))
  :effect (and (not (at ?from)) (at ?to) (increase (total-cost) 1)))
 (:action clear-box :parameters (?b - box ?here ?r - room)
  :precondition (and (at ?here) (adjacent ?here ?r) (in ?b ?r))
  :effect (and (not (in ?b ?r)) (increase (total-cost) 5))))
"""

ROOMS_PROBLEM = """
(define (problem through) (:domain rooms)
 (:objects r0 r1 - room bx - box)
 (:init (at r0) (adjacent r0 r1) (adjacent r1 r0) (in bx r1) (= (total-cost) 0))
 (:goal (at r1))
 (:metric minimize (total-cost)))
"""

PIGEON_DOMAIN = """
(define (domain pigeons)
 (:requirements :strips :typing :negative-preconditions)
 (:types pigeon hole)
 (:predicates (free ?h - hole) (placed ?p - pigeon) (in ?p - pigeon ?h - hole))
 (:action place :parameters (?p - pigeon ?h - hole)
  :precondition (and (free ?h) (not (placed ?p)))
  :effect (and (not (free ?h)) (placed ?p) (in ?p ?h))))
"""


def pigeon_problem(holes: int) -> str:
    """holes + 1 pigeons into `holes` holes: solvable when relaxed, unsolvable for real;
    the search has to exhaust a state space that grows exponentially with `holes`."""
    pigeons = " ".join(f"p{i}" for i in range(holes + 1))
    hole_names = " ".join(f"h{i}" for i in range(holes))
    free = " ".join(f"(free h{i})" for i in range(holes))
    goal = " ".join(f"(placed p{i})" for i in range(holes + 1))
    return (
        f"(define (problem pigeonhole) (:domain pigeons)"
        f" (:objects {pigeons} - pigeon {hole_names} - hole)"
        f" (:init {free}) (:goal (and {goal})))"
    )


@pytest.fixture(scope="module")
def planner() -> FastDownward:
    return FastDownward(DownwardConfig(max_time=10.0))


def test_solves_blocksworld_with_unit_costs(planner: FastDownward) -> None:
    plan = planner.solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM)
    assert plan.status is ClassicalStatus.SOLVED, plan.message
    assert len(plan.actions) == 6
    assert plan.cost == 6.0
    assert plan.actions[0] == ("unstack", ("c", "a"))  # lowercase, as FD prints
    assert plan.actions[-1] == ("stack", ("a", "b"))
    assert plan.translate_time > 0 and plan.search_time > 0


@pytest.mark.parametrize("search", [None, LAZY_WASTAR_FF])
def test_negated_derived_precondition_and_action_costs(search: str | None) -> None:
    config = DownwardConfig() if search is None else DownwardConfig(search=search)
    plan = FastDownward(config).solve(ROOMS_DOMAIN, ROOMS_PROBLEM)
    assert plan.status is ClassicalStatus.SOLVED, plan.message
    assert plan.actions == (("clear-box", ("bx", "r0", "r1")), ("move", ("r0", "r1")))
    assert plan.cost == 6.0


def test_goal_no_action_adds_is_unsolvable(planner: FastDownward) -> None:
    predicates = "(handempty) (holding ?x))"
    domain = BLOCKS_DOMAIN.replace(predicates, predicates[:-1] + " (glued ?x))")  # never added
    problem = BLOCKS_PROBLEM.replace("(on B C)", "(on B C) (glued A)")
    plan = planner.solve(domain, problem)
    assert plan.status is ClassicalStatus.UNSOLVABLE
    assert plan.actions == () and plan.cost is None
    assert "No relaxed solution" in plan.message
    assert plan.search_time == 0.0  # detected by the translator, no search process started


def test_relaxed_reachable_but_unsolvable_goal_is_proved_by_search(planner: FastDownward) -> None:
    plan = planner.solve(PIGEON_DOMAIN, pigeon_problem(3))
    assert plan.status is ClassicalStatus.UNSOLVABLE
    assert "exit code 11" in plan.message  # the search, not the translator, found it out
    assert plan.search_time > 0


def test_timeout_is_the_wall_clock_kill(planner: FastDownward) -> None:
    plan = planner.solve(PIGEON_DOMAIN, pigeon_problem(12), max_time=0.3)
    assert plan.status is ClassicalStatus.TIMEOUT
    assert "exceeded" in plan.message
    # the wall-clock kill ended it (CPU time never exceeds wall time, so the 1 s CPU rlimit
    # cannot come first): behaviour, not a measured duration
    assert "killed" in plan.message


def test_memory_limit_is_reported() -> None:
    # Blind A* stores states fast: the 30 MB address-space limit ends it long before the time
    # limit, which is generous so that a loaded machine still reaches the memory limit first.
    config = DownwardConfig(search="astar(blind())", memory_mb=30, max_time=120.0)
    plan = FastDownward(config).solve(PIGEON_DOMAIN, pigeon_problem(12))
    assert plan.status is ClassicalStatus.OUT_OF_MEMORY
    assert "memory limit 30 MB" in plan.message


def test_memory_too_small_to_start_is_not_a_crash() -> None:
    plan = FastDownward(DownwardConfig(memory_mb=5)).solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM)
    assert plan.status is ClassicalStatus.OUT_OF_MEMORY  # the loader cannot map libstdc++
    assert "memory" in plan.message


@pytest.mark.parametrize(
    ("domain", "problem", "expected"),
    [
        (BLOCKS_DOMAIN[:-3], BLOCKS_PROBLEM, "Missing ')'"),
        (BLOCKS_DOMAIN, BLOCKS_PROBLEM.replace("(on A B)", "(on A D)"), "Undefined object"),
        (BLOCKS_DOMAIN, BLOCKS_PROBLEM.replace(":domain blocks", ":domain other"), "domain name"),
    ],
)
def test_malformed_pddl_is_an_error(
    planner: FastDownward, domain: str, problem: str, expected: str
) -> None:
    plan = planner.solve(domain, problem)
    assert plan.status is ClassicalStatus.ERROR
    assert expected in plan.message
    assert "\n" not in plan.message


def test_search_option_error_is_reported() -> None:
    config = DownwardConfig(search="lazy_greedy([ff(axioms=approximate_negative)],bogus=1)")
    plan = FastDownward(config).solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM)
    assert plan.status is ClassicalStatus.ERROR
    assert plan.message == "search failed (exit code 33): Unknown keyword argument: bogus"


def test_unsupported_configuration_with_axioms_is_reported() -> None:
    plan = FastDownward(DownwardConfig(search="astar(lmcut())")).solve(ROOMS_DOMAIN, ROOMS_PROBLEM)
    assert plan.status is ClassicalStatus.ERROR
    assert "exit code 34" in plan.message and "axioms" in plan.message


def test_missing_binary_raises_planner_not_found() -> None:
    planner = FastDownward(binary=Path("/nonexistent"))
    with pytest.raises(PlannerNotFound, match="/nonexistent") as info:
        planner.solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM)
    assert "pip install up-fast-downward==1.0.0" in str(info.value)


def test_default_binary_is_found_and_cached() -> None:
    planner = FastDownward()
    assert planner.binary.name == "downward"
    assert planner.binary is planner.binary


@pytest.mark.parametrize(
    "search",
    [
        "lazy_greedy([ff()])",
        "lazy_greedy([ff(axioms=approximate_negative)],preferred=[add()])",
        "lazy_greedy([cg(axioms=approximate_negative_cycles)])",
        "eager_greedy([landmark_sum(lm_rhw())])",
    ],
)
def test_config_rejects_heuristics_without_approximate_negative(search: str) -> None:
    with pytest.raises(ValueError, match="axioms=approximate_negative"):
        DownwardConfig(search=search)


@pytest.mark.parametrize(
    "search",
    [
        LAZY_WASTAR_FF,
        "astar(blind())",
        "eager_greedy([landmark_sum(lm_rhw(),axioms=approximate_negative)])",
        "let(h,ff(axioms=approximate_negative),lazy_greedy([h],preferred=[h]))",
    ],
)
def test_config_accepts_valid_searches(search: str) -> None:
    assert DownwardConfig(search=search).search == search


def test_config_and_solve_reject_bad_limits() -> None:
    with pytest.raises(ValueError, match="max_time"):
        DownwardConfig(max_time=0.0)
    with pytest.raises(ValueError, match="max_time"):
        DownwardConfig(max_time=float("inf"))
    with pytest.raises(ValueError, match="memory_mb"):
        DownwardConfig(memory_mb=0)
    with pytest.raises(ValueError, match="max_time"):
        FastDownward().solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM, max_time=-1.0)


def test_plan_invariants() -> None:
    with pytest.raises(ValueError):
        ClassicalPlan(ClassicalStatus.TIMEOUT, (("a", ()),), None, 0.0, 0.0)
    with pytest.raises(ValueError):
        ClassicalPlan(ClassicalStatus.SOLVED, (), None, 0.0, 0.0)
    with pytest.raises(ValueError):
        ClassicalPlan(ClassicalStatus.ERROR, (), 1.0, 0.0, 0.0)


def test_parse_plan_reads_cost_comment_or_counts_actions() -> None:
    actions, cost = parse_plan("(pick b1 p0)\n(Place B1 T)\n; cost = 12 (general cost)\n")
    assert actions == (("pick", ("b1", "p0")), ("place", ("b1", "t")))
    assert cost == 12.0
    assert parse_plan("(noop)\n")[1] == 1.0


# --- limits on translation, crashes ------------------------------------------------------------


def blow_up_task(parameters: int = 8, objects: int = 40) -> tuple[str, str]:
    """One action with ``parameters`` parameters over ``objects`` objects: the translator would
    ground objects**parameters instances (6.5e12 here) and grow without bound."""
    params = " ".join(f"?v{i}" for i in range(parameters))
    pre = " ".join(f"(item ?v{i})" for i in range(parameters))
    domain = f"""(define (domain blowup) (:requirements :strips)
     (:predicates (item ?x) (done))
     (:action big :parameters ({params}) :precondition (and {pre}) :effect (done)))"""
    names = [f"o{i}" for i in range(objects)]
    init = " ".join(f"(item {n})" for n in names)
    problem = f"""(define (problem b) (:domain blowup) (:objects {" ".join(names)})
     (:init {init}) (:goal (done)))"""
    return domain, problem


@contextlib.contextmanager
def hang_guard(seconds: int) -> Iterator[None]:
    """Fail (instead of hanging the suite) if the block takes far longer than it may."""

    def expire(signum: int, frame: object) -> None:
        raise TimeoutError(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_translation_blow_up_ends_at_the_deadline_under_the_memory_limit() -> None:
    domain, problem = blow_up_task()
    with hang_guard(120):
        plan = FastDownward(DownwardConfig(max_time=2.0, memory_mb=1024)).solve(domain, problem)
    assert plan.status in (ClassicalStatus.TIMEOUT, ClassicalStatus.OUT_OF_MEMORY)
    assert plan.message.startswith("translat") and "\n" not in plan.message
    assert plan.search_time == 0.0  # no search was started
    peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    assert peak_kb < 2 * 1024 * 1024


def test_translation_blow_up_through_the_command_line(tmp_path: Path) -> None:
    domain, problem = blow_up_task()
    (tmp_path / "domain.pddl").write_text(domain)
    (tmp_path / "problem.pddl").write_text(problem)
    command = [sys.executable, "-m", "llmpas.cli", "plan", "domain.pddl", "problem.pddl"]
    done = subprocess.run(
        [*command, "--max-time", "2"], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert done.returncode != 0
    assert "Traceback" not in done.stdout + done.stderr
    assert done.stdout.splitlines()[0].startswith("timeout: classical planner: translation")
    assert resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss < 2 * 1024 * 1024


def test_translation_memory_limit_is_out_of_memory() -> None:
    domain, problem = blow_up_task()
    # the time limit is far above what reaching 64 MB takes (seconds), so that a loaded machine,
    # which gives the translator little CPU per wall second, still meets the memory limit first
    with hang_guard(660):
        plan = FastDownward(DownwardConfig(max_time=600.0, memory_mb=64)).solve(domain, problem)
    assert plan.status is ClassicalStatus.OUT_OF_MEMORY
    assert plan.message == "translator ran out of memory"


def _dying_binary(tmp_path: Path, signal_name: str) -> Path:
    script = tmp_path / "downward"
    script.write_text(f"#!/bin/sh\nkill -{signal_name} $$\n")
    script.chmod(0o755)
    return script


@pytest.mark.parametrize("signal_name", ["KILL", "SEGV", "TERM"])
def test_killed_search_is_crashed_not_timeout(tmp_path: Path, signal_name: str) -> None:
    planner = FastDownward(
        DownwardConfig(max_time=30.0), binary=_dying_binary(tmp_path, signal_name)
    )
    plan = planner.solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM)
    assert plan.status is ClassicalStatus.CRASHED
    assert f"SIG{signal_name}" in plan.message and "\n" not in plan.message


def test_killed_translator_is_crashed_not_timeout(monkeypatch: pytest.MonkeyPatch) -> None:
    def killed(*args: object) -> None:
        os.kill(os.getpid(), signal.SIGKILL)  # runs in the forked translator child

    monkeypatch.setattr(downward, "_run_translator", killed)
    plan = FastDownward(DownwardConfig(max_time=30.0)).solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM)
    assert plan.status is ClassicalStatus.CRASHED
    assert plan.message == "translator crashed (signal SIGKILL)"


def test_translator_errors_leave_the_caller_usable(planner: FastDownward) -> None:
    # a failed translation in the child changes nothing in this process: the next task plans
    assert planner.solve(BLOCKS_DOMAIN[:-3], BLOCKS_PROBLEM).status is ClassicalStatus.ERROR
    assert planner.solve(BLOCKS_DOMAIN, BLOCKS_PROBLEM).status is ClassicalStatus.SOLVED
