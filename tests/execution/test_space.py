"""The constraint space: lazy draws, conflict-directed backtracking, budgets, records."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from llmpas.execution.space import NO_SAMPLE, ConstraintSpace, Dimension, Exhausted


def space(max_samples: int = 50) -> ConstraintSpace:
    return ConstraintSpace(
        (
            Dimension("region", lambda v: ["a", "b"]),
            Dimension("base", lambda v: [f"{v['region']}{i}" for i in range(5)], budget=2),
            Dimension("grasp", lambda v: ["top", "fwd"]),
        ),
        fixed={"obj": "cube"},
        max_samples=max_samples,
    )


def test_values_are_drawn_lazily_and_conditionally() -> None:
    s = space()
    assert s.values() == {"obj": "cube"}
    assert s.value("base") == "a0"  # region drawn first, base conditioned on it
    assert s.values() == {"obj": "cube", "region": "a", "base": "a0"}


def test_backtrack_advances_the_culprit_and_forgets_deeper_dimensions() -> None:
    s = space()
    s.ensure(["grasp"])
    assert s.backtrack(["base"])
    assert s.values() == {"obj": "cube", "region": "a", "base": "a1"}  # grasp forgotten
    assert s.value("grasp") == "top"


def test_budget_of_a_dimension_moves_to_the_shallower_one() -> None:
    s = space()
    seen = []
    while True:
        seen.append(s.value("base"))
        if not s.backtrack(["base"]):
            break
    assert seen == ["a0", "a1", "b0", "b1"]  # base budget 2 per region
    assert s.exhausted
    with pytest.raises(Exhausted):
        s.value("base")


def test_whole_space_budget() -> None:
    s = space(max_samples=3)
    s.value("base")  # 2 samples
    assert s.backtrack(["base"])  # 3rd sample
    assert not s.backtrack(["base"])
    assert len(s.samples) == 3


def test_empty_sampler_backtracks_to_the_previous_dimension() -> None:
    s = ConstraintSpace(
        (Dimension("a", lambda v: [1, 2]), Dimension("b", lambda v: [] if v["a"] == 1 else [10]))
    )
    assert s.value("b") == 10 and s.values()["a"] == 2


def test_perceptions_reach_later_samplers() -> None:
    s = ConstraintSpace((Dimension("grasp", lambda v: [f"at {v['detected']}"]),))
    s.perceive("detected", (1.0, 2.0))
    assert s.value("grasp") == "at (1.0, 2.0)"


def test_every_sample_is_recorded() -> None:
    s = space()
    s.ensure(["grasp"])
    s.backtrack(["grasp"])
    assert s.tried() == {"region": ["'a'"], "base": ["'a0'"], "grasp": ["'top'", "'fwd'"]}


def test_bad_configuration() -> None:
    with pytest.raises(ValueError, match="budget"):
        Dimension("x", lambda v: [], budget=0)
    with pytest.raises(ValueError, match="repeat"):
        ConstraintSpace((Dimension("x", lambda v: []), Dimension("x", lambda v: [])))


def test_a_sampler_that_never_produces_a_value_uses_up_its_budget() -> None:
    def idle(values: object) -> Iterator[object]:
        while True:  # a stream yielding None forever
            yield NO_SAMPLE

    def late(values: object) -> Iterator[object]:
        yield NO_SAMPLE
        yield "found"

    s = ConstraintSpace((Dimension("a", lambda v: [1, 2]), Dimension("b", idle, budget=3)))
    with pytest.raises(Exhausted):
        s.value("b")
    assert s.exhausted
    assert ConstraintSpace((Dimension("c", late, budget=3),)).value("c") == "found"
