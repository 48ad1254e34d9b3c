"""A search sweeps (issue #35, item 4): the places one object-loss consultation yields are
searched in the method's order until the object is seen, within a budget the page shows. On a
scenario of its own (tests/data/loop/sweep-mug-microwave.toml: the mug is moved into the
microwave, the sixth place of the enumeration's order), each test failed before the sweep: one
consultation searched one place (or a goal-writer's places all at once, in the planner's order),
and three consultations were spent on the first three places."""

from __future__ import annotations

from pathlib import Path

from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.reasoning.methods import MethodConfig
from llmpas.system import LoopResult, loop_markdown
from tests.test_system import Scripted, clean_blackboard  # noqa: F401 (autouse)

MUG = str(Path(__file__).parent / "data" / "loop" / "sweep-mug-microwave.toml")


def config(method: str, **kw: object) -> LoopConfig:
    return LoopConfig(method=MethodConfig(method=method, seed=3), **kw)  # type: ignore[arg-type]


def looks(result: LoopResult) -> list[str]:
    """The places searched, in the order searched (one look a round)."""
    out = []
    for r in result.rounds:
        if r.episode is not None and r.goal.startswith("(and (scanned "):
            out += [g.strip("()").split()[1] for g in r.goal[5:-1].split(") (")]
    return out


def consultations(result: LoopResult) -> int:
    return sum(r.proposal is not None for r in result.rounds)


def test_candidates_first_sweeps_in_the_enumeration_s_order_and_stops_when_seen() -> None:
    result = run_loop(MUG, "oracle", config("candidates-first"))
    assert result.success, result.message
    assert consultations(result) == 1
    order = ["drawer1", "drawer2", "drawer3", "drawer4", "fridge", "microwave"]
    assert looks(result) == order  # stops at the microwave: the tables are not searched
    notes = [r.note for r in result.rounds if r.note]
    assert len(notes) == 6 and "budget at most 12 places, 100 actions" in notes[0]
    assert "sweep for mug" in loop_markdown(result)


def test_candidates_random_sweeps_in_its_own_order() -> None:
    result = run_loop(MUG, "oracle", config("candidates-random"))
    assert result.success, result.message
    assert consultations(result) == 1
    first = next(r.proposal for r in result.rounds if r.proposal is not None)
    ranked = [c.goals[0] for c in first.candidates if len(c.goals) == 1]
    ranked_looks = [str(g)[9:-1] for g in ranked if str(g).startswith("(scanned ")]
    searched = looks(result)
    assert searched[-1] == "microwave" and len(set(searched)) == len(searched)
    assert searched == ranked_looks[: len(searched)]  # the shuffled ranking's order


def test_a_goal_writer_s_places_are_searched_in_the_order_written_until_seen() -> None:
    """Four places written; the mug is in the second: the other two are never searched
    (before, the four were planned together and all searched, in the planner's order)."""
    llm = Scripted(
        "Goals: (and (scanned fridge) (scanned microwave) (scanned drawer1) (scanned drawer3))"
    )
    result = run_loop(MUG, llm)
    assert result.success, result.message
    assert looks(result) == ["fridge", "microwave"]


def test_the_budget_bounds_a_sweep_and_no_place_is_searched_twice() -> None:
    from llmpas.system.sweep import SweepBudget

    result = run_loop(MUG, "oracle", config("candidates-first", sweep=SweepBudget(places=2)))
    assert result.success, result.message
    assert consultations(result) == 3  # two places a consultation: the sixth in the third
    searched = looks(result)
    assert searched == ["drawer1", "drawer2", "drawer3", "drawer4", "fridge", "microwave"]
    assert "table2_right" not in searched  # the first look's place, searched in vain


def test_a_sweep_stops_by_its_counts_never_by_a_clock() -> None:
    """Issue #42: the budget is counted (places searched, actions planned for them), so the
    same sweep stops at the same place on any machine; there is no clock to give it."""
    from llmpas.language.logic import Atom
    from llmpas.system.sweep import Sweep, SweepBudget

    looks = [Atom("scanned", (p,)) for p in ("drawer1", "drawer2", "fridge")]
    by_actions = Sweep("mug", list(looks), SweepBudget(places=12, actions=5))
    by_actions.take(looks[0], 3)
    assert by_actions.over() == ""
    by_actions.take(looks[1], 3)
    assert by_actions.over() == "the budget's 5 actions are planned"
    by_places = Sweep("mug", list(looks), SweepBudget(places=1, actions=100))
    by_places.take(looks[0], 2)
    assert by_places.over() == "the budget's 1 places are searched"
    assert "seconds" not in SweepBudget.__dataclass_fields__
