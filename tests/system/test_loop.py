"""Round control's one backend shape (:mod:`llmpas.system.loop`): a factory of the session, built
once when the loop starts; :func:`~llmpas.system.loop.fixed` for a backend that does not depend
on the session."""

from __future__ import annotations

from typing import Any

import pytest

from llmpas.reasoning.llm import LLM, LLMError, Request, Response
from llmpas.system import LoopSettings, as_factory, close_loop, fixed
from llmpas.worlds.api import RunOptions
from llmpas.worlds.household.household_plugin import WORLD


class Answers:
    """Answers every request with the same goals."""

    name = "answers"

    def __init__(self, text: str) -> None:
        self.text = text
        self.asked = 0

    def complete(self, request: Request) -> Response:
        self.asked += 1
        return Response(self.text, model="answers")


def test_fixed_is_a_factory_of_one_backend() -> None:
    llm = Answers("Goals: (and)")
    factory = fixed(llm)
    assert not isinstance(factory, LLM)
    assert factory(object()) is llm and factory(None) is llm
    assert as_factory(llm)(object()) is llm
    assert as_factory(factory) is factory


def test_the_factory_is_built_once_on_the_session_the_loop_runs_on() -> None:
    seen: list[Any] = []
    llm = Answers("Goals: (and (scanned table2_right))")

    def factory(session: Any) -> LLM:
        seen.append(session)
        return llm

    with WORLD.open("object-loss-table", RunOptions()) as session:
        result = close_loop(session, factory, LoopSettings(max_rounds=2))
    assert seen == [session]  # built once, on this session
    assert llm.asked >= 2 and any(r.proposal for r in result.rounds)


def test_a_factory_that_fails_is_the_loops_llm_error() -> None:
    def factory(session: Any) -> LLM:
        raise LLMError("no such model")

    with WORLD.open("object-loss-table", RunOptions()) as session, pytest.raises(LLMError):
        close_loop(session, factory, LoopSettings(max_rounds=1))
