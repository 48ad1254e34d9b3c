"""The loop's LLM, in one shape: a factory of the session (:data:`LLMFactory`), called once when
the loop starts (:func:`fixed` makes one of a backend that does not depend on the session), and
what the loop wraps it in: :class:`Once` (an identical request is never sent twice in one run)
and :class:`ByDeadline` (answers must come before the loop's deadline). :func:`who` names what
answers in the loop's messages."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

from llmpas.reasoning.llm import LLM, Request, Response
from llmpas.worlds.api import Session

LLMFactory = Callable[[Any], LLM]  # Session -> LLM (Any: a world's own session type too)
LLMFor = LLMFactory  # its earlier name


def fixed(llm: LLM) -> LLMFactory:
    """The factory of a backend that does not depend on the session."""

    def factory(session: Session) -> LLM:
        return llm

    return factory


def as_factory(llm: LLM | LLMFactory) -> LLMFactory:
    """``llm`` as the loop takes it: a backend is :func:`fixed`, a factory stays itself."""
    return fixed(llm) if isinstance(llm, LLM) else llm


class DeadlineReached(Exception):
    """The loop's deadline passed while the LLM was answering."""


class ByDeadline:
    """An LLM whose answers must come before the loop's deadline: each call runs in a daemon
    thread that is abandoned when the time is up (the backend's own timeout still ends it)."""

    def __init__(self, inner: LLM, remaining: Callable[[], float]) -> None:
        self.inner = inner
        self.name = inner.name
        self.remaining = remaining
        self.role = who(inner)
        scorer = getattr(inner, "score", None)
        if callable(scorer):
            self.score = lambda request: self._call(scorer, request)

    def complete(self, request: Request) -> Response:
        response: Response = self._call(self.inner.complete, request)
        return response

    def _call(self, fn: Callable[[Any], Any], request: Any) -> Any:
        left = self.remaining()
        if left <= 0:
            raise DeadlineReached
        out: list[Any] = []

        def call() -> None:
            try:
                out.append(fn(request))
            except BaseException as err:  # handed over to the loop's thread
                out.append(err)

        worker = threading.Thread(target=call, name="llm-call", daemon=True)
        worker.start()
        worker.join(left if math.isfinite(left) else None)
        if not out:
            raise DeadlineReached
        if isinstance(out[0], BaseException):
            raise out[0]
        return out[0]


class Once:
    """An identical request is never sent twice in one run: a request (or a scoring request)
    whose key was sent before gets the answer given then (a fixed-seed model would give it
    again, and a round would be wasted asking)."""

    def __init__(self, inner: LLM) -> None:
        self.inner = inner
        self.name = inner.name
        self.role = who(inner)
        self.answers: dict[str, Any] = {}
        self.repeats = 0  # requests answered from what was sent before
        scorer = getattr(inner, "score", None)
        if callable(scorer):
            self.score = lambda request: self._once(scorer, request)

    def complete(self, request: Request) -> Response:
        response: Response = self._once(self.inner.complete, request)
        return response

    def _once(self, fn: Callable[[Any], Any], request: Any) -> Any:
        key = request.key()
        if key in self.answers:
            self.repeats += 1
            return self.answers[key]
        self.answers[key] = answer = fn(request)
        return answer


class Watched:
    """An LLM whose requests are told to ``prompted`` when they are sent and to ``replied``
    with their answer (a viewer's live feed); scoring requests pass unwatched."""

    def __init__(
        self,
        inner: LLM,
        prompted: Callable[[Request], object],
        replied: Callable[[Request, Response], object],
    ) -> None:
        self.inner = inner
        self.name = inner.name
        self.role = who(inner)
        self.prompted, self.replied = prompted, replied
        scorer = getattr(inner, "score", None)
        if callable(scorer):
            self.score = scorer

    def complete(self, request: Request) -> Response:
        self.prompted(request)
        response = self.inner.complete(request)
        self.replied(request, response)
        return response


def who(backend: object) -> str:
    """Who answers goal requests, in the loop's messages: ``the LLM``, unless the backend says
    it is something else (a labelled oracle, the replan baseline), so that their failures are
    not called the LLM's."""
    return str(getattr(backend, "role", "") or "the LLM")


__all__ = [
    "ByDeadline",
    "DeadlineReached",
    "LLMFactory",
    "LLMFor",
    "Once",
    "Watched",
    "as_factory",
    "fixed",
    "who",
]
