"""The first consultation of a run, taken apart without asking anyone (:func:`first_consultation`):
the loop runs until its first anomaly, and stops where it would consult the method; what comes
back is what any method would be given there: the anomaly, the prompt's situation, and the
candidate goal sets the loop enumerates (:mod:`llmpas.system.candidates`), each checked by the
loop's own validator. A measurement of what a model knows ranks the checked candidates with the
model, on the same situation, as ``flp-choose`` would (``llmpas bench knowledge``)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from llmpas.reasoning.goal_reading import Literal
from llmpas.reasoning.llm import LLMError, Request, Response
from llmpas.reasoning.methods import Situation
from llmpas.system.candidates import accepted_as
from llmpas.system.loop import Consulting, _Loop
from llmpas.system.settings import LoopSettings
from llmpas.worlds.api import Session


@dataclass(frozen=True)
class FirstConsultation:
    """What the first consultation of a run is given: the anomaly's text, the situation the
    prompt is written from, every candidate enumerated (in the enumeration's order) and those
    the loop's checks accept, as the checks read them."""

    anomaly: str
    situation: Situation
    candidates: tuple[tuple[Literal, ...], ...]
    checked: tuple[tuple[Literal, ...], ...]


class _Nobody:
    """A backend that must not be asked: the probe stops before any consultation."""

    name = "nobody"

    def complete(self, request: Request) -> Response:
        raise LLMError("the probe asks no model")


def first_consultation(session: Session, settings: LoopSettings) -> FirstConsultation | None:
    """Run ``session`` to its first consultation (None: the run needs none) and take it apart.
    The method is the enumeration's (``candidates-first``): the candidates do not depend on
    the method that would rank them."""
    method = replace(settings.method, method="candidates-first")
    loop = _Loop(session, replace(settings, method=method), probing=True)
    try:
        loop.run(_Nobody())
    except Consulting as stop:
        consult = loop.consult
        candidates = consult.candidates(stop.anomaly)
        checked = [accepted_as(consult.check, c) for c in candidates]
        return FirstConsultation(
            stop.anomaly.text,
            consult.situation(stop.anomaly),
            tuple(candidates),
            tuple(c for c in checked if c is not None),
        )
    return None


__all__ = ["FirstConsultation", "first_consultation"]
