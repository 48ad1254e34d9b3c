"""The loop's observer (llmpas.system.observe): a tiny in-memory observer records what the loop
tells it on a household run, in order, and a run without one builds nothing for it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pytest

from llmpas.execution.executor import Tick
from llmpas.planning import PlanResult
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.methods import Proposal
from llmpas.system import NoObserver, Observer, run
from llmpas.system.records import LoopResult, LoopStatus, Round
from llmpas.worlds.api import Session

SCENARIO = "object-loss-table"  # one anomaly (the cube is not where believed), one consultation


@dataclass
class Seen:
    """An :class:`Observer` that writes down every call."""

    calls: list[tuple[str, Any]] = field(default_factory=list)

    def started(self, session: Session) -> None:
        self.calls.append(("started", session.name))

    def planned(self, index: int, goal: str, plan: PlanResult) -> None:
        self.calls.append(("planned", (index, goal, plan.status.value)))

    def ticked(self, index: int, tick: Tick) -> None:
        self.calls.append(("ticked", (index, tick)))

    def executed(self, index: int, rnd: Round) -> None:
        self.calls.append(("executed", (index, rnd)))

    def prompted(self, index: int, request: Request) -> None:
        self.calls.append(("prompted", (index, request)))

    def replied(self, index: int, request: Request, response: Response) -> None:
        self.calls.append(("replied", (index, request, response)))

    def answered(self, index: int, proposal: Proposal) -> None:
        self.calls.append(("answered", (index, proposal)))

    def recorded(self, result: LoopResult) -> None:
        self.calls.append(("recorded", result))

    def of(self, kind: str) -> list[Any]:
        return [x for k, x in self.calls if k == kind]


def _run(observer: Observer | None) -> LoopResult:
    from llmpas.system.catalog import llm_for, load_world

    llm = llm_for("oracle", None, "household")
    return run(load_world("household"), SCENARIO, llm, observer=observer)


def test_the_loop_tells_its_observer_every_step_in_order() -> None:
    seen = Seen()
    assert isinstance(seen, Observer) and isinstance(NoObserver(), Observer)
    result = _run(seen)
    assert result.success
    kinds = [k for k, _ in seen.calls]
    assert kinds[0] == "started" and kinds[-1] == "recorded"
    # each round: planned, its ticks, executed (in that order, round by round)
    executed = seen.of("executed")
    assert [i for i, _ in executed] == list(range(len(result.rounds)))
    assert [r.goal for _, r in executed] == [r.goal for r in result.rounds]
    for i, rnd in enumerate(result.rounds):
        first = kinds.index("planned", kinds.index("started"))
        assert seen.of("planned")[i][:2] == (i, rnd.goal)
        ticks = [t for j, t in seen.of("ticked") if j == i]
        assert rnd.episode is not None and len(ticks) == rnd.episode.ticks
        assert [t.index for t in ticks] == list(range(1, rnd.episode.ticks + 1))
        assert first < kinds.index("executed")
    # the round with the anomaly is answered after it was executed, with the loop's proposal
    answered = seen.of("answered")
    asked = [(i, r.proposal) for i, r in enumerate(result.rounds) if r.proposal is not None]
    assert answered == asked and len(asked) == 1
    k = asked[0][0]
    at = seen.calls.index(("answered", asked[0]))
    assert seen.calls.index(("executed", (k, executed[k][1]))) < at
    # each request told when sent and when answered, before the consultation is done: the
    # proposal's exchanges, in order
    exchanges = [(k, e.request, e.response) for e in asked[0][1].exchanges]
    assert [(i, r) for i, r in seen.of("prompted")] == [(i, r) for i, r, _ in exchanges]
    replied = seen.of("replied")
    assert [(i, r, a.text) for i, r, a in replied] == [(i, r, a.text) for i, r, a in exchanges]
    for i, r, a in replied:
        assert seen.calls.index(("prompted", (i, r))) < seen.calls.index(("replied", (i, r, a)))
        assert seen.calls.index(("replied", (i, r, a))) < at
    # the records: running while the loop runs, the judged result last
    records = seen.of("recorded")
    assert all(r.status is LoopStatus.RUNNING for r in records[:-2])
    assert records[-1] == result


def test_a_tick_lists_the_tree_from_its_root() -> None:
    seen = Seen()
    _run(seen)
    _, tick = seen.of("ticked")[0]
    name, status, depth = tick.nodes[0]
    assert (name, depth) == ("plan", 0)
    assert all(d >= 1 for _, _, d in tick.nodes[1:])
    assert tick.steps and all(s >= 0 for s in tick.steps)
    assert tick.to_json()["nodes"][0] == {"name": "plan", "status": status, "depth": 0}


def test_a_run_without_an_observer_builds_no_tick(monkeypatch: pytest.MonkeyPatch) -> None:
    import llmpas.execution.executor as executor

    def refuse(*args: Any) -> Tick:
        raise AssertionError("a tick was built for nobody")

    monkeypatch.setattr(executor, "tick_of", refuse)
    assert _run(None).success
