"""The entry points: open a scenario of a world, run the closed loop on it
(:func:`~llmpas.system.loop.close_loop`) or plan and execute it once, judge the task in the
world's truth, and write the run folder.

**The truth judge.** A session with a true state (:class:`~llmpas.worlds.api.TrueFacts`) is
judged on it by :func:`~llmpas.worlds.api.holds`: the task's intent (``LoopSettings.success``)
where the run has one, else its goal. Any other session is judged by its ``achieved()`` (None:
the robot's belief decides). The result keeps both verdicts side by side: ``believed`` (the
loop's, in the robot's belief) and ``truth``; ``success`` is the truth where there is one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from llmpas.language.problem import parse_formula
from llmpas.reasoning.llm import LLM, LLMError, Request, Response
from llmpas.system.llm_factories import LLMFactory, fixed
from llmpas.system.loop import LoopSettings, close_loop
from llmpas.system.observe import Observer
from llmpas.system.records import (
    LoopResult,
    LoopStatus,
    OnRound,
    save_loop,
    save_once,
    save_records,
)
from llmpas.worlds.api import RunOptions, Session, TrueFacts, World, holds


def run(
    world: World,
    scenario: Any,
    llm: LLM | LLMFactory,
    settings: LoopSettings | None = None,
    options: RunOptions | None = None,
    out: str | Path | None = None,
    on_round: OnRound | None = None,
    observer: Observer | None = None,
) -> LoopResult:
    """Open ``scenario`` in ``world``, run the closed loop, judge the task in the world's truth
    (where the world has one) and, with ``out``, write the run folder (``loop.json`` and
    ``loop.md`` after every step, each round's episode and subtrees, the world's own files).
    ``llm``: a factory of the session, or a backend (read as
    :func:`~llmpas.system.llm_factories.fixed`); ``observer``: a viewer told of every step (its
    last record is the judged result)."""
    hooks = [h for h in (on_round, _records_to(out)) if h is not None]
    save = None if out is None else (lambda r, session: save_loop(r, out, session))
    settings = settings or LoopSettings()
    return _opened(world, scenario, llm, settings, options, hooks, save, observer)


def run_once(
    world: World,
    scenario: Any,
    options: RunOptions | None = None,
    out: str | Path | None = None,
    observer: Observer | None = None,
) -> LoopResult:
    """Plan the task once and execute it, with no LLM (one round), judged like :func:`run`;
    ``out``: an episode folder (the episode's reports and subtrees, the world's own files)."""
    save = None if out is None else (lambda r, session: save_once(r, out, session))
    no_llm = fixed(_NoLLM())
    settings = LoopSettings(max_rounds=0)
    return _opened(world, scenario, no_llm, settings, options, [], save, observer)


def _opened(
    world: World,
    scenario: Any,
    llm: LLM | LLMFactory,
    settings: LoopSettings,
    options: RunOptions | None,
    hooks: list[OnRound],
    save: Callable[[LoopResult, Session], object] | None,
    observer: Observer | None = None,
) -> LoopResult:
    """The loop on a session of ``world``, judged in its truth, then saved while it is open."""
    t0 = time.perf_counter()
    with world.open(scenario, options or RunOptions()) as session:
        on_round = _each(hooks) if hooks else None
        result = close_loop(session, llm, settings, on_round, observer=observer)
        # a task the loop carried a substitute into is judged as pursued (its intent, if any)
        success = settings.success or result.task or None
        result = judged(result, session, success, time.perf_counter() - t0)
        if observer is not None:
            observer.recorded(result)
        if save is not None:
            save(result, session)
    return result


class _NoLLM:
    """The backend of a run without reasoning: never asked (no LLM rounds are allowed)."""

    name = "none"

    def complete(self, request: Request) -> Response:
        raise LLMError("no LLM in this run")


def _records_to(out: str | Path | None) -> OnRound | None:
    return None if out is None else (lambda result: save_records(result, out))


def _each(hooks: list[OnRound]) -> OnRound:
    def call(result: LoopResult) -> None:
        for hook in hooks:
            hook(result)

    return call


def truth(session: Session, success: str | None = None) -> bool | None:
    """The task judged in the session's true state: its intent ``success`` (PDDL) where the run
    has one, else its goal (None: the world has no true state and no judge)."""
    if isinstance(session, TrueFacts):
        intent = parse_formula(success or session.task, session.domain)
        return holds(intent, session.true_facts())
    return session.achieved()


def judged(
    result: LoopResult, session: Session, success: str | None = None, seconds: float = 0.0
) -> LoopResult:
    """The loop's result with the world's verdict beside the robot's (when the loop ended by
    itself and the world has a judge) and the world's timings (``total``: ``seconds``)."""
    timings = {**session.timings, **result.timings, "total": seconds}
    ended = result.status not in (LoopStatus.DONE, LoopStatus.NOT_DONE)
    verdict = None if ended else truth(session, success)
    if verdict is None:
        return replace(result, timings=timings)
    if getattr(session, "verdict_basis", "truth") == "perceived":  # no ground truth to judge on
        return replace(result, success=verdict, timings=timings, status=None, basis="perceived")
    return replace(
        result, success=verdict, timings=timings, status=None, truth=verdict, basis="truth"
    )


__all__ = ["judged", "run", "run_once", "truth"]
