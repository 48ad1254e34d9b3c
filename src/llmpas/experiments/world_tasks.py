"""Any registered world's scenarios as tasks of the prompting experiment (``llmpas bench
prompting --world NAME``).

A task here is one shipped scenario of a world (:meth:`~llmpas.worlds.api.World.scenarios`): the
world opens it, the closed loop runs it, and the run is judged from the loop's own result
(:func:`judge_scenario`), which holds the robot's verdict (``believed``) beside the world's
(``truth``: the task judged by the world's truth judge, :class:`~llmpas.worlds.api.TrueFacts`
and :func:`~llmpas.worlds.api.holds`, or the session's own ``achieved()``):

- ``no-anomaly``: no round met an anomaly (no episode failed, the LLM was never consulted);
- ``not-done``: the loop did not believe the task done;
- ``false-done``: it believed the task done, the world's truth disagrees;
- ``success``: it believed the task done and the truth agrees. A world with no truth to judge
  on gives what the robot perceived: the judgement's ``basis`` says ``perceived`` (else
  ``truth``).

The task's category (the table's column) is the world's name; it has no ground-truth resolution
length (``l_gt`` is None: the table shows no ASPL) and no effective goal sets.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from llmpas.errors import UsageError
from llmpas.experiments.suite.judge import (
    Judgement,
    Verdict,
    answer_counts,
    first_anomaly,
    first_answer_goals,
    proposal_fields,
)
from llmpas.experiments.worlds import LoopConfig
from llmpas.reasoning.goal_reading import GoalParse
from llmpas.reasoning.llm import LLM
from llmpas.reasoning.methods import Situation, answer_reader
from llmpas.system import LLMFor, LoopResult, run
from llmpas.system.catalog import load_world, scenario_arg
from llmpas.worlds.api import Session


@dataclass(frozen=True)
class WorldTask:
    """One shipped scenario of a world, as a task: ``world`` as asked (a registered name or
    ``package.module:WORLD``), ``name`` the scenario's, ``category`` the world's own name and
    ``description`` the scenario's line."""

    world: str
    name: str
    category: str
    description: str = ""

    def __post_init__(self) -> None:
        if not self.world or not self.name or not self.category:
            raise ValueError("a world's task needs its world, its scenario and its category")

    @property
    def source(self) -> str:
        """Where the task comes from (the world and the scenario)."""
        return f"{self.world}/{self.name}"

    @property
    def digest(self) -> str:
        """What its runs' cache keys hold of it."""
        text = "\0".join((self.world, self.name, self.category, self.description))
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    @property
    def l_gt(self) -> None:
        """No ground-truth resolution length is known for a world's scenario."""
        return None


def world_tasks(world: str, names: Sequence[str] | None = None) -> tuple[WorldTask, ...]:
    """The scenarios of ``world`` (or only ``names``) as tasks, in the world's order. An unknown
    world or scenario: a one-line :class:`~llmpas.errors.UsageError` naming the option."""
    found = load_world(world)  # names --world when it is unknown
    shipped = found.scenarios()
    if not shipped:
        raise UsageError(f"--world {world}: the world ships no scenarios")
    missing = sorted(set(names or ()) - set(shipped))
    if missing:
        known = ", ".join(shipped)
        raise UsageError(f"--tasks: no scenario {missing[0]!r} in {world}; known: {known}")
    wanted = set(shipped if names is None else names)
    return tuple(WorldTask(world, n, found.name, shipped[n]) for n in shipped if n in wanted)


def world_task(world: str, name: str) -> WorldTask:
    """One scenario of ``world`` as a task (a job's, read again where it runs)."""
    return world_tasks(world, [name])[0]


def judge_scenario(
    task: WorldTask,
    llm: LLM | LLMFor,
    config: LoopConfig,
    keep: Callable[[LoopResult], object] | None = None,
) -> Judgement:
    """Run ``task`` through the closed loop with ``llm`` (a backend or a function of the
    session) and judge it from the loop's result (``keep``: called with it, e.g. to save it)."""
    start = time.perf_counter()
    sessions: list[Session] = []

    def factory(session: Session) -> LLM:
        sessions.append(session)
        return llm if isinstance(llm, LLM) else llm(session)

    scenario = scenario_arg(task.world, task.name)
    result = run(load_world(task.world), scenario, factory, config, config.options)
    if keep is not None:
        keep(result)
    first = _first_trouble(result)
    proposals = [r.proposal for r in result.rounds if r.proposal is not None]
    read = _reader(sessions[0], config) if sessions else None
    answers, syntax = answer_counts(proposals, read)
    first_goals = first_answer_goals(proposals[0], read) if proposals and read else ()
    return Judgement(
        task=task.name,
        category=task.category,
        verdict=verdict(result, first is not None),
        completed=bool(result.believed),
        resolution_length=_resolution(result, first[0]) if first else 0,
        anomaly=first[1] if first else "",
        rounds=len(result.rounds),
        answers=answers,
        syntax_errors=syntax,
        **proposal_fields(proposals),
        message=result.message,
        wall_time=time.perf_counter() - start,
        first_goals=" ".join(map(str, first_goals)),
        basis="truth" if result.truth is not None else "perceived",
    )


def verdict(result: LoopResult, anomaly: bool) -> Verdict:
    """The verdict of a run from its result: the loop's own (``believed``) against the world's
    truth (``truth``; None: the world has none, and what the robot perceived, ``success``,
    decides)."""
    if not anomaly:
        return Verdict.NO_ANOMALY
    if not result.believed:
        return Verdict.NOT_DONE
    holds = result.truth if result.truth is not None else result.success
    return Verdict.SUCCESS if holds else Verdict.FALSE_DONE


def _first_trouble(result: LoopResult) -> tuple[int, str] | None:
    """The round of the run's first anomaly and its violated constraint: the first episode's
    anomaly or, before it, a round that consulted the LLM without one (no plan)."""
    found = first_anomaly(result)
    asked = next((i for i, r in enumerate(result.rounds) if r.proposal is not None), None)
    if found is not None and (asked is None or found[0] <= asked):
        return found[0], str(found[1].constraint)
    if asked is None:
        return None
    return asked, f"no plan ({result.rounds[asked].plan.status.value})"


def _resolution(result: LoopResult, index: int) -> int:
    """Plan actions completed after round ``index``."""
    later = result.rounds[index + 1 :]
    return sum(len(r.episode.completed) for r in later if r.episode is not None)


def _reader(session: Session, config: LoopConfig) -> Callable[[str], GoalParse]:
    """How the method reads a goal answer in the session's world (its vocabulary, its calls)."""
    blank = Situation("", "", "", "", "", calls=session.prompts.calls)
    read, _ = answer_reader(blank, session.vocabulary, config.method)
    return read


__all__ = ["WorldTask", "judge_scenario", "verdict", "world_task", "world_tasks"]
