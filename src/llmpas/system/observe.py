"""Watching the loop: :class:`Observer`, what the loop tells a viewer while it runs (a live
view, a recording; :mod:`llmpas.reporting.live` is one), and :class:`NoObserver`, the default,
which does nothing (a run without a viewer builds nothing for one).

The loop calls an observer at fixed points: the session opened, a plan made, every tick of the
behaviour tree, a round executed (its anomaly, the belief), each request to the LLM when it is
sent and when it is answered, a consultation done (its exchanges, the validator's verdict) and
every record of the loop (its round and status). An
observer reads what it is given and the session it was handed; it never changes them.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from llmpas.execution.executor import Tick
from llmpas.planning import PlanResult
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.methods import Proposal
from llmpas.system.records import LoopResult, Round
from llmpas.worlds.api import Session


@runtime_checkable
class Observer(Protocol):
    """What the loop tells a viewer; ``index``: the round (0 first)."""

    def started(self, session: Session) -> None:
        """The session the loop runs on (its scene, belief and task)."""
        ...

    def planned(self, index: int, goal: str, plan: PlanResult) -> None:
        """The plan of round ``index`` for ``goal`` (no plan: ``plan.plan`` is None)."""
        ...

    def ticked(self, index: int, tick: Tick) -> None:
        """The behaviour tree after one tick of round ``index``."""
        ...

    def executed(self, index: int, rnd: Round) -> None:
        """Round ``index`` executed (its episode, with the anomaly report if one stopped it)."""
        ...

    def prompted(self, index: int, request: Request) -> None:
        """A request sent to the LLM about round ``index``'s anomaly, before it answers."""
        ...

    def replied(self, index: int, request: Request, response: Response) -> None:
        """The LLM's answer to ``request``."""
        ...

    def answered(self, index: int, proposal: Proposal) -> None:
        """The consultation after round ``index``: its exchanges (each prompt and answer, those
        told already included) and the validator's verdict."""
        ...

    def recorded(self, result: LoopResult) -> None:
        """The loop's record so far (status ``running``), or its last one."""
        ...


class NoObserver:
    """The observer of a run nobody watches: every call does nothing."""

    def started(self, session: Session) -> None:
        return None

    def planned(self, index: int, goal: str, plan: PlanResult) -> None:
        return None

    def ticked(self, index: int, tick: Tick) -> None:
        return None

    def executed(self, index: int, rnd: Round) -> None:
        return None

    def prompted(self, index: int, request: Request) -> None:
        return None

    def replied(self, index: int, request: Request, response: Response) -> None:
        return None

    def answered(self, index: int, proposal: Proposal) -> None:
        return None

    def recorded(self, result: LoopResult) -> None:
        return None


__all__ = ["NoObserver", "Observer"]
