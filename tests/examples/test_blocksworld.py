"""The blocks-world example: files, generator, and plans that replay to the goal."""

from __future__ import annotations

import itertools
from importlib.resources import as_file, files

import pytest

from llmpas.examples.blocksworld import (
    PACKAGE,
    generate,
    make_problem,
    problem_text,
    shipped_problem_text,
)
from llmpas.examples.blocksworld.generator import Towers, tower_facts
from llmpas.language.problem import read_problem
from llmpas.language.semantics import Semantics, replay

Step = tuple[str, tuple[str, ...]]


def constructive_plan(init: Towers, goal: Towers) -> list[Step]:
    """Unstack everything onto the table, then build the goal towers bottom-up."""
    steps: list[Step] = []
    for tower in init:
        for below, top in reversed(list(itertools.pairwise(tower))):
            steps += [("unstack", (top, below)), ("putdown", (top,))]
    for tower in goal:
        for below, top in itertools.pairwise(tower):
            steps += [("pickup", (top,)), ("stack", (top, below))]
    return steps


def test_domain_has_the_four_operators() -> None:
    p = make_problem(3, 0)
    assert sorted(a.name for a in p.domain.actions) == ["pickup", "putdown", "stack", "unstack"]
    assert not p.streams.streams


def test_shipped_problem_is_the_generated_one() -> None:
    assert shipped_problem_text() == problem_text(5, 0)
    root = files(PACKAGE)
    with as_file(root / "domain.pddl") as d, as_file(root / "problem.pddl") as pr:
        from_file = read_problem(d, pr)
    generated = make_problem(5, 0)
    assert from_file.init == generated.init
    assert from_file.goal == generated.goal
    assert set(from_file.objects) == set(generated.objects)


@pytest.mark.parametrize("n", [2, 3, 5, 8, 12])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_instances_are_well_formed(n: int, seed: int) -> None:
    inst = generate(n, seed)
    for towers in (inst.init, inst.goal):
        assert sorted(b for t in towers for b in t) == sorted(inst.blocks)
    assert tower_facts(inst.init) != tower_facts(inst.goal)
    assert generate(n, seed) == inst


def test_too_few_blocks() -> None:
    with pytest.raises(ValueError, match="at least 2"):
        generate(1, 0)


@pytest.mark.parametrize("n", [2, 4, 6, 9])
@pytest.mark.parametrize("seed", [0, 7])
def test_constructive_plan_replays_to_goal(n: int, seed: int) -> None:
    p = make_problem(n, seed)
    inst = generate(n, seed)
    sem = Semantics(p.domain, dict.fromkeys(p.objects, "object"))
    assert not sem.holds(p.goal, p.init)
    r = replay(sem, p.init, constructive_plan(inst.init, inst.goal), p.goal)
    assert r.valid, r.message


def test_a_wrong_plan_does_not_replay() -> None:
    p = make_problem(4, 0)
    sem = Semantics(p.domain, dict.fromkeys(p.objects, "object"))
    inst = generate(4, 0)
    bottom = next(t[0] for t in inst.init if len(t) > 1)
    r = replay(sem, p.init, [("pickup", (bottom,))], p.goal)
    assert not r.valid and r.failed_step == 0
