"""``State.successor``: the state after adds and deletes, sharing what they do not touch, reads
as the state built from scratch (facts, membership, sorted atoms, argument indexes)."""

from __future__ import annotations

import random

from llmpas.language.logic import Atom
from llmpas.language.semantics import State


def _atom(rng: random.Random) -> Atom:
    pred = rng.choice(["at", "on", "clear", "holding"])
    return Atom(pred, tuple(rng.choice("abcde") for _ in range(rng.randint(0, 2))))


def test_successor_reads_as_the_state_built_from_scratch() -> None:
    rng = random.Random(3)
    for _ in range(200):
        facts = {_atom(rng) for _ in range(rng.randint(0, 25))}
        state = State(facts)
        state.atoms("at")  # indexes built before the step are shared or dropped, never stale
        state.atoms_with("on", 0, "a")
        assert Atom("clear", ("b",)) in state or True
        adds = {_atom(rng) for _ in range(rng.randint(0, 4))}
        dels = {_atom(rng) for _ in range(rng.randint(0, 4))} | set(
            rng.sample(sorted(facts, key=str), min(2, len(facts)))
        )
        expected = (facts - dels) | adds
        got = state.successor(adds, dels)
        fresh = State(expected)
        for a in expected | dels | {_atom(rng) for _ in range(5)}:
            assert (a in got) == (a in expected)
        for pred in ("at", "on", "clear", "holding", "none"):
            assert got.atoms(pred) == fresh.atoms(pred)
            assert got.count(pred) == fresh.count(pred)
            for pos in (0, 1):
                for v in "abcde":
                    assert got.atoms_with(pred, pos, v) == fresh.atoms_with(pred, pos, v)
        assert got.facts == frozenset(expected)
        assert state.facts == frozenset(facts)  # the parent is unchanged
        again = got.successor(dels, adds)  # a second step from a successor
        assert again.facts == frozenset((expected - adds) | dels)
