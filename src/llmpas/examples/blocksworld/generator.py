"""Seeded random blocks-world problems: random initial towers, random goal towers."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from llmpas.examples._files import load_domain, read_text
from llmpas.language.problem import Problem

PACKAGE = "llmpas.examples.blocksworld"

Towers = tuple[tuple[str, ...], ...]  # each tower listed bottom to top
Fact = tuple[str, ...]


@dataclass(frozen=True)
class BlocksInstance:
    """One generated instance: the block names, the initial towers and the goal towers."""

    blocks: tuple[str, ...]
    init: Towers
    goal: Towers

    @property
    def name(self) -> str:
        return f"bw-{len(self.blocks)}"


def random_towers(blocks: tuple[str, ...], rng: np.random.Generator) -> Towers:
    """Shuffle the blocks and cut the sequence into towers at random points."""
    order = [blocks[i] for i in rng.permutation(len(blocks))]
    towers: list[tuple[str, ...]] = []
    current: list[str] = []
    for b in order:
        if current and rng.random() < 0.4:
            towers.append(tuple(current))
            current = []
        current.append(b)
    towers.append(tuple(current))
    return tuple(towers)


def tower_facts(towers: Towers) -> frozenset[Fact]:
    """``ontable``/``on`` facts describing ``towers`` (their order does not matter)."""
    out: set[Fact] = set()
    for t in towers:
        out.add(("ontable", t[0]))
        out.update(("on", top, below) for below, top in itertools.pairwise(t))
    return frozenset(out)


def generate(n_blocks: int, seed: int) -> BlocksInstance:
    """The instance of size ``n_blocks`` for ``seed`` (the goal always differs from the start)."""
    if n_blocks < 2:
        raise ValueError(f"blocks world needs at least 2 blocks, got {n_blocks}")
    rng = np.random.default_rng(seed)
    blocks = tuple(f"b{i + 1}" for i in range(n_blocks))
    init = random_towers(blocks, rng)
    goal = random_towers(blocks, rng)
    while tower_facts(goal) == tower_facts(init):
        goal = random_towers(blocks, rng)
    return BlocksInstance(blocks, init, goal)


def init_facts(inst: BlocksInstance) -> list[Fact]:
    clear = [("clear", t[-1]) for t in inst.init]
    return [("handempty",), *sorted(tower_facts(inst.init)), *sorted(clear)]


def goal_facts(inst: BlocksInstance) -> list[Fact]:
    return sorted(tower_facts(inst.goal))


def make_problem(n_blocks: int, seed: int) -> Problem:
    """A blocks-world :class:`Problem` with ``n_blocks`` blocks (no streams)."""
    inst = generate(n_blocks, seed)
    return Problem.create(
        load_domain(PACKAGE),
        init=init_facts(inst),
        goal=goal_facts(inst),
        objects=inst.blocks,
        name=f"{inst.name}-{seed}",
    )


def problem_text(n_blocks: int, seed: int) -> str:
    """The same instance as :func:`make_problem`, written as a ``problem.pddl``."""
    inst = generate(n_blocks, seed)
    init = "\n".join(f"    {_fact(f)}" for f in init_facts(inst))
    goal = "\n".join(f"      {_fact(f)}" for f in goal_facts(inst))
    towers = "; ".join(" ".join(t) for t in inst.goal)
    return (
        f"; {n_blocks} blocks, seed {seed}; goal towers (bottom to top): {towers}\n"
        f"(define (problem {inst.name}-{seed})\n"
        "  (:domain blocksworld)\n"
        f"  (:objects {' '.join(inst.blocks)})\n"
        f"  (:init\n{init})\n"
        f"  (:goal (and\n{goal})))\n"
    )


def shipped_problem_text() -> str:
    """The text of the shipped ``problem.pddl`` (``problem_text(5, 0)``)."""
    return read_text(PACKAGE, "problem.pddl")


def _fact(f: Fact) -> str:
    return "(" + " ".join(f) + ")"
