"""Which of the LLM's goals made the difference in a closed loop, and what replanning alone did.

Read from a run folder's record (:class:`~llmpas.reporting.run_folder.RunRecord`): each LLM answer's
goals and what became of them (rejected, not reached, reached), the goals reached last before the
task was done (the *decisive* ones), and, when the run folder holds the replan-only run of the
same scenario and seed (``about.json``'s ``baseline``: a folder relative to the run's), that run's
verdict. From these, one sentence says why the LLM mattered (or did not).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from llmpas.reporting.run_folder import RunRecord, get_str

MAX_BASELINE_BYTES = 50_000_000


@dataclass(frozen=True)
class Outcome:
    """One LLM answer: the goals taken and what became of them."""

    round: int  # the round whose anomaly was answered
    goals: tuple[str, ...]
    fate: str  # "rejected" | "not reached" | "reached" | "not tried"


@dataclass(frozen=True)
class Baseline:
    """The replan-only run of the same scenario and seed."""

    folder: str  # relative to the run's folder
    success: bool | None
    message: str
    rounds: int


@dataclass(frozen=True)
class Difference:
    outcomes: tuple[Outcome, ...]
    decisive: tuple[str, ...]  # goals reached last before the task was done
    baseline: Baseline | None
    verdict: str  # one or two sentences


def outcomes(run: RunRecord) -> tuple[Outcome, ...]:
    out = []
    rounds = list(run.rounds)
    for k, r in enumerate(rounds):
        x = r.reasoning
        if x is None:
            continue
        if x.status != "ok" or not x.goals:
            out.append(Outcome(r.index, x.goals, "rejected"))
            continue
        nxt = rounds[k + 1] if k + 1 < len(rounds) else None
        fate = (
            "not tried" if nxt is None else "reached" if nxt.status == "success" else "not reached"
        )
        out.append(Outcome(r.index, x.goals, fate))
    return tuple(out)


def baseline_of(run: RunRecord) -> Baseline | None:
    """The replan-only run the folder's ``about.json`` names (None: none, or unreadable)."""
    rel = get_str(run.about, "baseline")
    if not rel:
        return None
    path = run.folder / rel / "loop.json"
    try:
        if path.stat().st_size > MAX_BASELINE_BYTES:
            return None
        data: Any = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    success = data.get("success")
    rounds = data.get("rounds")
    return Baseline(
        rel,
        success if isinstance(success, bool) else None,
        get_str(data, "message"),
        len(rounds) if isinstance(rounds, list) else 0,
    )


def difference(run: RunRecord) -> Difference:
    found = outcomes(run)
    reached = [o for o in found if o.fate == "reached"]
    decisive = reached[-1].goals if run.success and reached else ()
    base = baseline_of(run)
    return Difference(found, decisive, base, _verdict(run, found, decisive, base))


def _verdict(
    run: RunRecord, found: tuple[Outcome, ...], decisive: tuple[str, ...], base: Baseline | None
) -> str:
    if base is None:
        alone = ""
    elif base.success:
        alone = "Replanning alone (the task restated, no LLM) also finished the task: "
        alone += "this run does not need its LLM. "
    elif base.success is False:
        alone = f"Replanning alone (the task restated, no LLM) did not finish: {base.message}. "
    else:
        alone = "The replan-only run has no verdict. "
    if not found:
        return alone + "The LLM was not asked."
    if decisive:
        return alone + (
            f"The LLM's goals {' '.join(decisive)} were reached in round "
            f"{next(o.round for o in found if o.goals == decisive) + 1}, and from what the robot "
            "then believed the task was planned and done."
        )
    if run.success:
        return alone + "The task was done, but no goal of the LLM was reached before it."
    return alone + "The LLM's goals did not lead to the task being done."


__all__ = ["Baseline", "Difference", "Outcome", "baseline_of", "difference", "outcomes"]
