"""The closed LLM-PAS loop on the PyBullet world: plan -> execute -> on an anomaly, ask the
reasoner (``llmpas.reasoning``, unchanged) for goals -> replan from the believed state -> resume.

The loop itself is :func:`llmpas.system.close_loop` (the same one the household runs, with the
same checks of the LLM's goals); this module is the world it runs on
(:class:`PyBulletLoopWorld`, the :class:`llmpas.system.LoopWorld` of a :class:`Session`), its
prompt text, its oracle and its output (snapshots, a GIF, per-round reports, ``loop.json``).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from types import MappingProxyType
from typing import Any

from llmpas.execution.anomaly import AnomalyReport
from llmpas.execution.context import Belief
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode
from llmpas.execution.report import save_episode
from llmpas.files import atomic_write
from llmpas.language.domain import Domain
from llmpas.language.logic import Atom, Formula, Not
from llmpas.planning import PlanResult
from llmpas.reasoning.goals import Vocabulary
from llmpas.reasoning.llm import LLM, Request, Response
from llmpas.reasoning.methods import Situation
from llmpas.reasoning.program import Call
from llmpas.system import (
    LoopResult,
    LoopSettings,
    LoopStatus,
    Round,
    close_loop,
    loop_markdown,
)
from llmpas.worlds.kitchen import load_domain
from llmpas.worlds.pybullet.decomposition import table_of
from llmpas.worlds.pybullet.problem import believed_pose
from llmpas.worlds.pybullet.run import PyBulletRun, RunConfig, Scenario, Session, resolve, save_run
from llmpas.worlds.pybullet.scene import SceneConfig, open_client

ACTIONS = {
    "pick": ("pick up an object from a table or a bowl (the hand must be empty)", ("holding",)),
    "place": ("put the held object on a table or into a bowl (one object per bowl)", ("on",)),
    "scan_table": ("drive to a table and look at it, finding what is on it", ("scanned",)),
}
PREDICATES = {
    "on": ("?o ?r", "object ?o rests on table ?r or in bowl ?r"),
    "holding": ("?o", "the robot holds object ?o"),
    "scanned": ("?r", "the robot has looked at table ?r"),
}
PROGRAM_CALLS = MappingProxyType(
    {
        "pick": Call(("obj",), "holding", (0,)),
        "place": Call(("obj", "region"), "on", (0, 1)),
        "scan_table": Call(("region",), "scanned", (0,)),
    }
)


@dataclass(frozen=True)
class LoopConfig(LoopSettings):
    run: RunConfig = field(default_factory=RunConfig)


def vocabulary(config: SceneConfig) -> Vocabulary:
    objects = frozenset(o.name for o in config.objects if o.kind == "cube")
    everything = frozenset(o.name for o in config.objects)
    tables = frozenset(t.name for t in config.tables)
    bowls = frozenset(o.name for o in config.objects if o.kind == "bowl")
    return Vocabulary(
        {"on": (everything, tables | bowls), "holding": (objects,), "scanned": (tables,)}
    )


def environment(config: SceneConfig, belief: Belief) -> str:
    lines = []
    for o in config.objects:
        pose = believed_pose(belief, o.name)
        held = bool(belief.matching("atgrasp", o.name))
        where = "held by the robot" if held else f"on {pose.region}" if pose else "location unknown"
        lines.append(f"- {o.name} ({o.colour} {o.kind}): {where}")
    lines.append(f"- tables: {', '.join(t.name for t in config.tables)}")
    return "\n".join(lines)


def situation(
    config: SceneConfig, belief: Belief, report: AnomalyReport, task: str, history: str = ""
) -> Situation:
    # no ``example=``: the default format example comes from another domain on purpose (an
    # example naming objects of this world would leak an answer)
    return Situation(
        anomaly=report.describe(),
        actions="\n".join(
            f"- {n}: {t} — makes true: {', '.join(m)}" for n, (t, m) in ACTIONS.items()
        ),
        predicates="\n".join(f"- ({n} {a}): {t}" for n, (a, t) in PREDICATES.items()),
        environment=environment(config, belief),
        task=f"the robot must achieve {task}",
        history=history,
        calls=PROGRAM_CALLS,
        objects=tuple(sorted(o.name for o in config.objects)),
    )


class Oracle:
    """**Oracle** (an upper bound, never a default): goals from the simulator's TRUE state."""

    name = "oracle"

    def __init__(self, session: Session, report: Callable[[], AnomalyReport | None]) -> None:
        self.session = session
        self.report = report

    def complete(self, request: Request) -> Response:
        r = self.report()
        if request.tag == "first-look" or r is None:
            return Response("Look where the truth says.", model="oracle")
        goals = self.goals(r)
        return Response(f"(and {' '.join(map(str, goals))})", model="oracle")

    def goals(self, r: AnomalyReport) -> list[Atom | Not]:
        c = r.constraint
        atom = c.arg if isinstance(c, Not) else c
        if not isinstance(atom, Atom):
            return []
        scene = self.session.scene
        if atom.predicate == "on" and not isinstance(c, Not):
            at, _ = scene.pose(atom.args[0])
            table = next(
                (t for t, rect in scene.tables.items() if rect.contains(at[0], at[1])), None
            )
            return [Atom("scanned", (table,))] if table else []
        if atom.predicate == "full":
            bowl = atom.args[0]
            blockers = [
                o.name
                for o in scene.config.objects
                if o.kind == "cube" and o.name != scene.held and self._in(o.name, bowl)
            ]
            occupied = {
                t
                for o in scene.config.objects
                for t, rect in scene.tables.items()
                if rect.contains(*scene.pose(o.name)[0][:2]) and o.name != scene.held
            }
            free = [t for t in sorted(scene.tables) if t not in occupied] or sorted(scene.tables)
            return [Atom("on", (blockers[0], free[0]))] if blockers else []
        return []

    def _in(self, obj: str, bowl: str) -> bool:
        scene = self.session.scene
        a, _ = scene.pose(obj)
        b, _ = scene.pose(bowl)
        half = scene.config.obj(bowl).size / 2
        return abs(a[0] - b[0]) < half and abs(a[1] - b[1]) < half


@dataclass(frozen=True)
class PyBulletLoopWorld:
    """A :class:`Session` as the closed loop sees it (:class:`llmpas.system.LoopWorld`); it
    keeps each executed episode's CSubBTs for the episode folder."""

    session: Session
    vocabulary: Vocabulary
    domain: Domain
    executed: list[tuple[tuple[SubtreeSpec, ...], Episode]] = field(default_factory=list)

    @classmethod
    def of(cls, session: Session) -> PyBulletLoopWorld:
        return cls(session, vocabulary(session.scene.config), load_domain())

    @property
    def name(self) -> str:
        return self.session.scenario.name

    @property
    def task(self) -> str:
        return self.session.scenario.goal

    @property
    def belief(self) -> Belief:
        return self.session.belief

    def plan(self, goal: Formula | str, index: int) -> tuple[PlanResult, Any]:
        return self.session.plan(goal)

    def execute(self, plan: PlanResult, problem: Any) -> Episode | None:
        specs, episode = self.session.execute(plan, problem)
        if episode is not None:
            self.executed.append((specs, episode))
        return episode

    def specs(self, episode: Episode) -> tuple[SubtreeSpec, ...]:
        return next(s for s, e in self.executed if e is episode)

    def situation(self, report: AnomalyReport, history: str) -> Situation:
        scenario = self.session.scenario
        return situation(scenario.scene, self.belief, report, scenario.goal, history)

    def search_places(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.session.scene.config.tables)

    def looked_at(self, report: AnomalyReport) -> tuple[str, ...]:
        """The table a failed detection looked at (the region's, for a bowl)."""
        c = report.constraint
        if not isinstance(c, Atom) or len(c.args) < 2:
            return ()
        return (table_of(self.session.scene.config, self.belief, c.args[1]),)

    def lost(self, obj: str) -> bool:
        return (
            any(o.name == obj for o in self.session.scene.config.objects)
            and believed_pose(self.belief, obj) is None
            and not self.belief.matching("atgrasp", obj)
        )


def run_loop(
    scenario: Scenario | str,
    llm: LLM | Callable[[Session, Callable[[], AnomalyReport | None]], LLM],
    config: LoopConfig | None = None,
    out: str | Path | None = None,
) -> LoopResult:
    """Run a PyBullet scenario with LLM recovery (``llm``: a backend, or a factory getting the
    session and the current anomaly, which is how the oracle is built). ``success``: the task
    goal holds in the simulator's true state at the end (judged afterwards)."""
    config = config or LoopConfig()
    scenario = resolve(scenario)
    t0 = time.perf_counter()
    records = None if out is None else partial(save_records, folder=out)
    with open_client(config.run.gui) as cid:
        session = Session(scenario, config.run, cid)
        world = PyBulletLoopWorld.of(session)
        if isinstance(llm, LLM):
            result = close_loop(world, llm, config, records)
        else:
            factory = llm
            result = close_loop(world, lambda report: factory(session, report), config, records)
        session.world.snapshot("end")
        timings = dict(session.timings, total=time.perf_counter() - t0)
        ended = result.status not in (LoopStatus.DONE, LoopStatus.NOT_DONE)
        status = result.status if ended else None  # None: from success, judged in the truth
        result = replace(result, success=session.achieved(), timings=timings, status=status)
        if out is not None:
            save_loop(result, world, out)
    return result


def save_loop(result: LoopResult, world: PyBulletLoopWorld, folder: str | Path) -> list[Path]:
    """The episode folder of the last executed round (report, snapshots, GIF, CSubBT XML), each
    executed round's report in ``round-I``, ``loop.json`` and ``loop.md`` (every prompt and
    answer, the goals taken and the repairs)."""
    out = Path(folder)
    written: list[Path] = []
    if world.executed:
        session = world.session
        specs, episode = world.executed[-1]
        run = PyBulletRun(
            session.scenario,
            result.rounds[-1].plan,
            specs,
            episode,
            result.success,
            dict(result.timings),
            tuple(session.world.log),
        )
        written += save_run(run, session.world, out)
        for i, rnd in enumerate(result.rounds):
            if rnd.episode is not None:
                title = f"{result.scenario}, round {i}"
                written += save_episode(
                    rnd.episode, out / f"round-{i}", world.specs(rnd.episode), title
                )
    return written + save_records(result, out)


def save_records(result: LoopResult, folder: str | Path) -> list[Path]:
    """``loop.json`` and ``loop.md`` (every prompt and answer), atomically; written after every
    round while the loop runs, so a crash or an interrupt keeps what happened."""
    out = Path(folder)
    return [
        atomic_write(out / "loop.json", json.dumps(loop_json(result), indent=2)),
        atomic_write(out / "loop.md", loop_markdown(result)),
    ]


def loop_json(result: LoopResult) -> dict[str, Any]:
    """The rounds of a loop: goals, plans, outcomes, anomalies and the reasoner's answers."""
    rounds = []
    for r in result.rounds:
        item: dict[str, Any] = {
            "goal": r.goal,
            "plan": [str(s) for s in r.plan.plan.steps] if r.plan.plan else None,
            "status": r.episode.status.value if r.episode else "no-plan",
            "anomaly": r.episode.anomaly.to_json() if r.episode and r.episode.anomaly else None,
        }
        if r.proposal is not None:
            item["reasoning"] = {
                **(r.to_json().get("reasoning") or {}),  # the exchanges (prompts and answers)
                "method": r.proposal.method,
                "goals": [str(g) for g in r.proposal.goals],
                "errors": list(r.proposal.parse.errors),
                "notes": list(r.proposal.parse.notes),
                "first_look": r.proposal.first_look,
            }
        rounds.append(item)
    return {
        "scenario": result.scenario,
        "success": result.success,
        "message": result.message,
        "status": result.status.value if result.status else None,
        "error": result.error or None,
        "llm_calls": result.llm_calls,
        "llm_time": round(result.llm_time, 3),
        "timings": {k: round(v, 3) for k, v in result.timings.items()},
        "rounds": rounds,
    }


def oracle_factory(session: Session, report: Callable[[], AnomalyReport | None]) -> LLM:
    return Oracle(session, report)


__all__ = [
    "LoopConfig",
    "LoopResult",
    "Oracle",
    "PyBulletLoopWorld",
    "Round",
    "loop_json",
    "oracle_factory",
    "run_loop",
    "save_loop",
    "save_records",
]
