"""What a closed loop leaves behind: its rounds (:class:`Round`), its result (:class:`LoopResult`,
with the robot's belief and the world's truth side by side), the readable report
(:func:`loop_markdown`) and the run folder (:func:`save_loop`, :func:`save_once`,
:func:`save_records`)."""

from __future__ import annotations

import html
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode
from llmpas.files import atomic_write
from llmpas.planning import PlanResult
from llmpas.reasoning.methods import Proposal
from llmpas.safetext import fenced, printable

if TYPE_CHECKING:
    from llmpas.worlds.api import Session


#: How a check was decided: a search made in vain before, the domain's invariants, the belief,
#: no action that makes a literal true, the planner, or a limit of the planner (no verdict).
DECIDED_BY = ("repeat", "invariant", "already true", "no action makes it", "search", "limit")


@dataclass(frozen=True)
class CheckRecord:
    """One check of a goal set: ``verdict`` ("accepted" or the rejection's status), ``by``
    (:data:`DECIDED_BY`, or "unchecked"), its time and the planner calls it made."""

    goals: str
    verdict: str
    by: str
    seconds: float
    planner_calls: int

    def to_json(self) -> dict[str, Any]:
        return {
            "goals": self.goals,
            "verdict": self.verdict,
            "by": self.by,
            "seconds": round(self.seconds, 4),
            "planner_calls": self.planner_calls,
        }


@dataclass(frozen=True)
class Round:
    """One plan-and-execute round, and the LLM's answer to its anomaly (if any)."""

    goal: str
    plan: PlanResult
    episode: Episode | None
    proposal: Proposal | None = None
    specs: tuple[SubtreeSpec, ...] = field(default=(), compare=False, repr=False)
    note: str = ""  # what the loop says of the round (a sweep's look, a substitution)
    checks: tuple[CheckRecord, ...] = ()  # the checks its consultation made, in order

    def to_json(self) -> dict[str, Any]:
        ep = self.episode
        out: dict[str, Any] = {
            "goal": self.goal,
            "plan": self.plan.to_json(),
            "status": ep.status.value if ep else "no-plan",
            "anomaly": ep.anomaly.to_json() if ep and ep.anomaly else None,
            "episode": ep.to_json() if ep else None,
        }
        if self.proposal is not None:
            out["reasoning"] = _proposal_json(self.proposal)
        if self.note:
            out["note"] = self.note
        if self.checks:
            out["checks"] = [c.to_json() for c in self.checks]
        return out


def _proposal_json(p: Proposal) -> dict[str, Any]:
    return {
        "method": p.method,
        "status": p.parse.status.value,
        "goals": [str(g) for g in p.goals],
        "errors": list(p.parse.errors),
        "notes": list(p.parse.notes),
        "repairs": p.repairs,
        "first_look": p.first_look,
        "candidates": [
            {"goals": c.text, "score": c.score, "chosen": c is p.chosen} for c in p.candidates
        ],
        "tokens": p.tokens,
        "latency": p.latency,
        "exchanges": [
            {
                "tag": e.tag,
                "messages": [[m.role, m.content] for m in e.request.messages],
                "response": e.response.text,
                "model": e.response.model,
                "prompt_tokens": e.response.prompt_tokens,
                "completion_tokens": e.response.completion_tokens,
                "latency": e.response.latency,
            }
            for e in p.exchanges
        ],
    }


class LoopStatus(Enum):
    """How a loop ended (``running``: a record written while it runs)."""

    DONE = "done"
    NOT_DONE = "not-done"
    DEADLINE = "deadline"
    LLM_ERROR = "llm-error"
    CRASHED = "crashed"
    ROBOT_LOST = "robot-lost"  # the robot went away mid-run (llmpas.errors.RobotLostError)
    INTERRUPTED = "interrupted"
    RUNNING = "running"


@dataclass(frozen=True)
class LoopResult:
    """``success``: the verdict, judged in the world's truth where the session has a true state
    (or a judge), else the robot's belief. ``believed``: the loop's own verdict, in the robot's
    belief (None: ``success``); ``truth``: the truth judge's (None: no true state, or not
    judged). A robot that carried a lookalike has ``believed`` true and ``truth`` false."""

    scenario: str
    success: bool  # judged in the world's truth where it has a judge, else the robot's belief
    rounds: tuple[Round, ...]
    message: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)  # seconds, where a world counts
    llm_time: float = 0.0  # seconds spent proposing goals (the LLM and the checks of its answers)
    status: LoopStatus | None = None  # None: done or not-done, from ``success``
    error: str = ""  # what stopped the loop when it did not end by itself
    believed: bool | None = None  # the loop's verdict in the robot's belief (None: ``success``)
    truth: bool | None = None  # the task judged in the world's true state (None: not judged)
    # what ``success`` was judged on: "truth" (the world's true state), "perceived" (what a
    # robot without ground truth perceived: a real or standard robot's), "" (the belief)
    basis: str = ""
    # the task the loop pursued at the end when it carried a substitute into it ("": as given),
    # and what it substituted and why
    task: str = ""
    substitutions: tuple[str, ...] = ()
    # how every plan the run made ended (status -> count), checks included: a ``timeout`` is a
    # time limit that fired (a safety net), the one outcome that depends on the machine
    plans: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.status is None:
            done = LoopStatus.DONE if self.success else LoopStatus.NOT_DONE
            object.__setattr__(self, "status", done)
        if self.believed is None:
            object.__setattr__(self, "believed", self.success)

    @property
    def llm_calls(self) -> int:
        return sum(len(r.proposal.exchanges) for r in self.rounds if r.proposal)

    @property
    def verdicts(self) -> str:
        """Belief and truth side by side: ``believed done, truly not done``, say."""
        believed = "believed done" if self.believed else "believed not done"
        if self.basis == "perceived":
            return f"{believed}, {'perceived done' if self.success else 'perceived not done'}"
        if self.truth is None:
            return f"{believed}, no truth judged"
        return f"{believed}, {'truly done' if self.truth else 'truly not done'}"

    def to_json(self) -> dict[str, Any]:
        substituted = {"task": self.task, "substitutions": list(self.substitutions)}
        return {
            "scenario": self.scenario,
            "success": self.success,
            "believed": self.believed,
            "truth": self.truth,
            "verdict_basis": self.basis or "belief",
            "message": self.message,
            "status": self.status.value if self.status else None,
            "error": self.error or None,
            "llm_calls": self.llm_calls,
            "llm_time": round(self.llm_time, 3),
            "timings": {k: round(v, 3) for k, v in self.timings.items()},
            "rounds": [r.to_json() for r in self.rounds],
            **({"plans": dict(self.plans)} if self.plans else {}),
            **(substituted if self.substitutions else {}),
        }

    def save(self, path: str | Path) -> Path:
        return atomic_write(path, json.dumps(self.to_json(), indent=2))


OnRound = Callable[[LoopResult], object]  # gets the record so far after every step


def loop_markdown(result: LoopResult) -> str:
    """The closed loop as a readable report: the verdict (belief and truth side by side), each
    round's goal and outcome, and for each anomaly the prompts sent, the answers, the goals
    taken and the repairs."""
    verdict = "task done" if result.success else "not done"
    if result.status not in (LoopStatus.DONE, LoopStatus.NOT_DONE, None):
        verdict += f" ({result.status.value})"
    title = f"# Closed loop: {_md(result.scenario)}"
    lines = [title, "", f"**{verdict}**: {_md(result.message)}", ""]
    if result.truth is not None:
        lines += [f"Belief and truth: {result.verdicts}", ""]
    elif result.basis == "perceived":
        lines += [f"Verdict: {result.verdicts} (what the robot perceived; no ground truth)", ""]
    if result.substitutions:
        lines += [f"The task pursued: `{_md(result.task)}`", ""]
        lines += [f"- substituted: {_md(s)}" for s in result.substitutions] + [""]
    for i, rnd in enumerate(result.rounds):
        ep = rnd.episode
        status = ep.status.value if ep else f"no plan ({rnd.plan.status.value})"
        lines += [f"## Round {i}: `{rnd.goal}` -> {status}", ""]
        if rnd.note:
            lines += [f"*{_md(rnd.note)}*", ""]
        if rnd.plan.plan is not None:
            lines += [
                f"Plan ({len(rnd.plan.plan.steps)} actions, {rnd.plan.stats.total_time:.2f} s):",
                "",
            ]
            lines += [f"{k}. `{s}`" for k, s in enumerate(rnd.plan.plan.steps, 1)] + [""]
        if ep is not None and ep.anomaly is not None:
            lines += ["Anomaly:", "", f"> {_md(ep.anomaly.describe())}", ""]
        if rnd.proposal is not None:
            lines += _proposal_lines(rnd.proposal)
    return printable("\n".join(lines) + "\n")


def _md(text: str) -> str:
    """Text from outside (an answer, a file name) on a Markdown line: one printable line, with
    no raw HTML."""
    return html.escape(printable(text, keep_newlines=False), quote=False)


def _proposal_lines(p: Proposal) -> list[str]:
    goals = " ".join(map(str, p.goals)) or f"none ({p.parse.status.value})"
    lines = [
        f"### Reasoning ({p.method}): {goals}",
        "",
        f"{p.repairs} repairs, {p.tokens} tokens, {p.latency:.1f} s",
        "",
    ]
    notes = [f"- {_md(e)}" for e in (*p.parse.errors, *p.parse.notes)]
    lines += [*notes, ""] if notes else []
    for e in p.exchanges:
        lines += [
            f"#### {_md(e.tag)}: prompt",
            "",
            *fenced(e.request.messages[-1].content.strip()),
            "",
            f"#### {_md(e.tag)}: answer ({_md(e.response.model)})",
            "",
            *fenced(e.response.text.strip()),
            "",
        ]
    return lines


def save_loop(result: LoopResult, folder: str | Path, session: Session | None = None) -> list[Path]:
    """The run folder: the world's own files (snapshots, a GIF, its log), per executed round
    ``round-I/`` with the episode report and the subtrees' XML, ``loop.json`` and ``loop.md``."""
    from llmpas.execution.report import save_episode

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = session.save(out) if session is not None else []
    for i, rnd in enumerate(result.rounds):
        if rnd.episode is not None:
            title = f"{result.scenario}, round {i}: {rnd.goal}"
            files += save_episode(rnd.episode, out / f"round-{i}", list(rnd.specs), title)
    return files + save_records(result, out)


def save_once(result: LoopResult, folder: str | Path, session: Session | None = None) -> list[Path]:
    """The folder of a run without reasoning: the world's own files and the one round's
    episode reports and subtrees at the top."""
    from llmpas.execution.report import save_episode

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = session.save(out) if session is not None else []
    rnd = result.rounds[0] if result.rounds else None
    if rnd is not None and rnd.episode is not None:
        files += save_episode(rnd.episode, out, list(rnd.specs), f"{result.scenario}: {rnd.goal}")
    return files


def save_records(result: LoopResult, folder: str | Path) -> list[Path]:
    """``loop.json`` and ``loop.md`` (atomically): written after every step while the loop
    runs, so a crash or an interrupt keeps what happened."""
    out = Path(folder)
    return [result.save(out / "loop.json"), atomic_write(out / "loop.md", loop_markdown(result))]


__all__ = [
    "LoopResult",
    "LoopStatus",
    "OnRound",
    "Round",
    "loop_markdown",
    "save_loop",
    "save_once",
    "save_records",
]
