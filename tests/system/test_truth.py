"""One truth judge (:func:`llmpas.worlds.api.holds` over a session's true facts), shared by every
world and by the suite's judge; ``run`` records the robot's belief and the truth side by side.

The must-show of #25: a household robot that took a lookalike for the object it was asked to
hold believes the task done, and the run records "believed done, truly not done"."""

from __future__ import annotations

import itertools
import json
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType

import pytest

from llmpas.experiments.suite import holds_in_truth, load_suite
from llmpas.language.logic import And, Atom, Imply, Not, Or
from llmpas.language.sexpr import SExpr, SList, parse_all
from llmpas.reasoning.llm import LLMError, Request, Response
from llmpas.system import LoopResult, LoopSettings, LoopStatus, judged, loop_markdown, run, truth
from llmpas.worlds.api import RunOptions, Session, TrueFacts, holds
from llmpas.worlds.household.household_plugin import WORLD, HouseholdSession
from llmpas.worlds.household.state import TrueState, true_facts

DATA = Path(__file__).resolve().parents[1] / "data" / "loop"


class NoLLM:
    """A backend that must not be asked."""

    name = "none"

    def complete(self, request: Request) -> Response:
        raise LLMError("asked")


# ----------------------------------------------------------------------------- holds


def a(text: str) -> Atom:
    name, *args = text.strip("()").split()
    return Atom(name, tuple(args))


FACTS = frozenset({a("(on cup t1)"), a("(open drawer)")})


@pytest.mark.parametrize(
    ("goal", "expected"),
    [
        (a("(on cup t1)"), True),
        (a("(on cup t2)"), False),  # not among the facts: false (a closed world)
        (Not(a("(on cup t2)")), True),
        (And((a("(on cup t1)"), a("(open drawer)"))), True),
        (And((a("(on cup t1)"), a("(holding cup)"))), False),
        (And(()), True),
        (Or((a("(holding cup)"), a("(open drawer)"))), True),
        (Or(()), False),
        (Imply(a("(holding cup)"), a("(on cup t9)")), True),
        (Imply(a("(open drawer)"), a("(on cup t9)")), False),
        (Atom("=", ("cup", "cup")), True),
    ],
)
def test_holds_reads_a_ground_formula_in_a_closed_world(goal: object, expected: bool) -> None:
    assert holds(goal, FACTS) is expected  # type: ignore[arg-type]


def test_holds_reads_pddl_text_in_lower_case() -> None:
    assert holds("(and (On Cup t1) (not (Holding cup)))", FACTS)
    assert not holds("(or (holding cup) (on cup t2))", FACTS)


@pytest.mark.parametrize(
    "goal",
    ["(exists (?x) (on ?x t1))", "(on ?x t1)", "(on cup t1) (open drawer)", "cup", "(not a b)"],
)
def test_holds_refuses_what_a_truth_judge_cannot_read(goal: str) -> None:
    with pytest.raises(ValueError):
        holds(goal, FACTS)


# ------------------------------------------------------------- the household's true facts


def _before(e: SExpr, truth: TrueState) -> bool:
    """The suite's own evaluator over the household's true state, as it was before #25."""
    assert isinstance(e, SList)
    head = e.head()
    if head == "and":
        return all(_before(i, truth) for i in e.items[1:])
    if head == "or":
        return any(_before(i, truth) for i in e.items[1:])
    if head == "not":
        return not _before(e.items[1], truth)
    args = [str(x) for x in e.items[1:]]
    if head == "on":
        obj, region = args
        p = truth.placements.get(obj)
        return obj != truth.held and p is not None and p.region == region
    if head == "holding":
        return truth.held == args[0]
    if head == "open":
        return bool(truth.open.get(args[0], False))
    return head in truth.properties.get(args[0], set())


def test_the_suite_judges_as_it_did_before_on_every_shipped_task() -> None:
    """Every shipped task's success formula, and every atom over its objects and regions, in
    its true initial state and with an object in the hand: the one truth judge agrees with the
    suite's former evaluator."""
    checked = 0
    for task in load_suite():
        truth = task.scenario.initial_state()
        objects = sorted(truth.placements)
        regions = sorted({p.region for p in truth.placements.values()} | set(truth.open))
        atoms = [f"(on {o} {r})" for o, r in itertools.product(objects, regions)]
        atoms += [f"(holding {o})" for o in objects] + [f"(open {r})" for r in regions]
        atoms += [f"({s} {o})" for o in objects for s in ("dirty", "cleaned", "cooked", "wet")]
        for state in (truth, _holding(truth, objects[0])):
            for text in (task.success, *atoms, f"(not {task.success})"):
                expr = parse_all(text, "t")[0]
                assert holds_in_truth(text, state) is _before(expr, state), (task.name, text)
                checked += 1
    assert checked > 1000


def _holding(truth: TrueState, obj: str) -> TrueState:
    held = TrueState(truth.layout, truth.specs, truth.base)
    held.placements = {o: p for o, p in truth.placements.items() if o != obj}
    held.held = obj
    held.open = dict(truth.open)
    held.properties = {o: set(s) for o, s in truth.properties.items()}
    return held


def test_the_household_true_facts_name_where_objects_truly_are() -> None:
    task = load_suite()[0]
    truth = task.scenario.initial_state()
    facts = true_facts(truth)
    for obj, p in truth.placements.items():
        assert Atom("on", (obj, p.region)) in facts
    assert not any(f.predicate == "holding" for f in facts)


# ------------------------------------------------------------------ sessions and runs


def test_every_household_session_has_a_truth_judge() -> None:
    with WORLD.open("lookalike-apple", RunOptions()) as session:
        assert isinstance(session, TrueFacts) and isinstance(session, HouseholdSession)
        assert session.achieved() is False  # never None: the robot's belief no longer decides
        assert truth(session) is False
        assert truth(session, "(not (holding apple))") is True  # the run's intent, if given


def test_a_lookalike_run_records_believed_done_truly_not_done(tmp_path: Path) -> None:
    """The robot is told the apple is on table1_left; a red apple lies there, which its detector
    takes for the apple. It picks it up and believes the task ``(holding apple)`` done."""
    settings = LoopSettings(max_rounds=0)
    result = run(WORLD, DATA / "lookalike-held.toml", NoLLM(), settings, out=tmp_path)
    assert result.believed is True and result.truth is False
    assert result.success is False and result.status is LoopStatus.NOT_DONE
    assert result.verdicts == "believed done, truly not done"
    saved = json.loads((tmp_path / "loop.json").read_text())
    assert (saved["success"], saved["believed"], saved["truth"]) == (False, True, False)
    assert saved["status"] == "not-done"
    assert "Belief and truth: believed done, truly not done" in (tmp_path / "loop.md").read_text()


class _NoTruth:
    """A session of a world with no true state and no judge (only what ``truth`` reads)."""

    task = "(and)"
    timings: Mapping[str, float] = MappingProxyType({})

    def achieved(self) -> bool | None:
        return None


def test_a_world_without_a_true_state_keeps_the_belief() -> None:
    session = _NoTruth()
    assert not isinstance(session, TrueFacts)
    assert truth(session) is None  # type: ignore[arg-type]
    result = LoopResult("s", True, (), "the task is done")
    out = judged(result, session)  # type: ignore[arg-type]
    assert (out.success, out.believed, out.truth) == (True, True, None)
    assert "Belief and truth" not in loop_markdown(out)


def test_a_loop_stopped_by_its_deadline_is_not_judged() -> None:
    class Judge(_NoTruth):
        def achieved(self) -> bool | None:
            raise AssertionError("judged")

    stopped = LoopResult("s", False, (), "deadline", status=LoopStatus.DEADLINE)
    out = judged(stopped, Judge())  # type: ignore[arg-type]
    assert out.status is LoopStatus.DEADLINE and out.truth is None


def test_the_session_protocol_still_holds() -> None:
    with WORLD.open("lookalike-apple", RunOptions()) as session:
        assert isinstance(session, Session)
