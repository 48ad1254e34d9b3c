"""Run a stack of CSubBTs tick by tick; stop on the first unrecoverable anomaly.

``execute(specs, ctx)`` builds one py_trees tree (a memory sequence of the CSubBTs), ticks it until
it succeeds, fails with an anomaly report, or runs out of its tick budget, and returns an
:class:`Episode`: the immutable record of what happened.

While a skill runs (a robot's goal), the tree keeps ticking, one tick per ``period``: each tick
polls the skill and checks its guards, which may preempt it. Ctrl-C stops the tree, which
cancels the running skill, and goes on as KeyboardInterrupt.
"""

from __future__ import annotations

import enum
import json
import logging
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import py_trees
from py_trees.common import Status

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.context import Context, Event
from llmpas.execution.csubbt import Explore, SubtreeSpec, build_subtree
from llmpas.files import atomic_write
from llmpas.language.logic import Atom

log = logging.getLogger(__name__)


class ExecStatus(enum.Enum):
    SUCCESS = "success"
    ANOMALY = "anomaly"
    BUDGET = "budget-exhausted"


@dataclass(frozen=True)
class ExecutorConfig:
    """``max_ticks`` bounds the ticks that move the tree on (every one runs at least one
    node); the ticks that only wait for a running skill are bounded by ``max_waits`` (and by
    the skill's own timeout), one per ``period`` seconds."""

    max_ticks: int = 2_000
    period: float = 0.02  # seconds from one tick to the next while a skill runs
    max_waits: int = 1_000_000

    def __post_init__(self) -> None:
        if self.max_ticks < 1:
            raise ValueError(f"max_ticks must be >= 1, got {self.max_ticks}")
        if not 0.0 <= self.period <= 10.0:
            raise ValueError(f"period must be in [0, 10] seconds, got {self.period}")
        if self.max_waits < 1:
            raise ValueError(f"max_waits must be >= 1, got {self.max_waits}")


@dataclass(frozen=True)
class Episode:
    """What happened when a plan was executed."""

    status: ExecStatus
    subtrees: tuple[str, ...]
    completed: tuple[int, ...]  # plan step indices whose subtree succeeded
    anomaly: AnomalyReport | None
    events: tuple[Event, ...]
    belief: frozenset[Atom]
    ticks: int
    retries: int  # backtracks over all subtrees
    message: str = ""

    def __post_init__(self) -> None:
        if (self.anomaly is not None) != (self.status is ExecStatus.ANOMALY):
            raise ValueError("an anomaly report is present exactly when the status is ANOMALY")

    @property
    def succeeded(self) -> bool:
        return self.status is ExecStatus.SUCCESS

    def to_json(self) -> dict[str, Any]:
        return {
            "status": self.status.value,
            "message": self.message,
            "subtrees": list(self.subtrees),
            "completed_steps": list(self.completed),
            "anomaly": self.anomaly.to_json() if self.anomaly else None,
            "ticks": self.ticks,
            "retries": self.retries,
            "belief": sorted(str(a) for a in self.belief),
            "timeline": [
                {
                    "t": round(e.t, 4),
                    "node": e.node,
                    "status": e.status,
                    "message": e.message,
                    "values": dict(e.values),
                }
                for e in self.events
            ],
        }

    def save(self, path: str | Path) -> Path:
        """Write the episode as JSON (atomically: a partial file is never left behind)."""
        return atomic_write(path, json.dumps(self.to_json(), indent=2))


@dataclass(frozen=True)
class Tick:
    """The tree after one tick, for a viewer: every node's ``(name, status, depth)`` in
    depth-first order, and the plan steps of the subtree that is running (or last ran)."""

    index: int
    nodes: tuple[tuple[str, str, int], ...]
    steps: tuple[int, ...]
    status: str

    def to_json(self) -> dict[str, Any]:
        return {
            "tick": self.index,
            "status": self.status,
            "steps": list(self.steps),
            "nodes": [{"name": n, "status": s, "depth": d} for n, s, d in self.nodes],
        }


OnTick = Callable[[Tick], object]


def tick_of(root: py_trees.behaviour.Behaviour, subtrees: Sequence[Explore], index: int) -> Tick:
    """The :class:`Tick` of the tree ``root`` after tick ``index``."""
    nodes: list[tuple[str, str, int]] = []

    def walk(node: py_trees.behaviour.Behaviour, depth: int) -> None:
        nodes.append((node.name, node.status.value, depth))
        for child in node.children:
            walk(child, depth + 1)

    walk(root, 0)
    ran = [s for s in subtrees if s.status is not Status.INVALID]
    steps = tuple(ran[-1].spec.steps) if ran else ()
    return Tick(index, tuple(nodes), steps, root.status.value)


def build_tree(
    specs: Sequence[SubtreeSpec], ctx: Context
) -> tuple[py_trees.composites.Sequence, list[Explore]]:
    run = uuid.uuid4().hex[:8]
    subtrees = [build_subtree(s, ctx, f"{run}/{i}") for i, s in enumerate(specs)]
    root = py_trees.composites.Sequence("plan", memory=True, children=list(subtrees))
    return root, subtrees


def execute(
    specs: Sequence[SubtreeSpec],
    ctx: Context,
    config: ExecutorConfig | None = None,
    on_tick: OnTick | None = None,
) -> Episode:
    """Tick the plan's subtrees to an end; ``on_tick`` gets the tree after every tick (a
    viewer's feed; nothing is built for it when it is None)."""
    config = config or ExecutorConfig()
    root, subtrees = build_tree(specs, ctx)
    ticks = waits = 0
    try:
        while ticks - waits < config.max_ticks and waits < config.max_waits:
            start, polls = time.monotonic(), ctx.polls
            root.tick_once()
            ticks += 1
            if on_tick is not None:
                on_tick(tick_of(root, subtrees, ticks))
            if root.status in (Status.SUCCESS, Status.FAILURE):
                break
            if ctx.polls != polls:  # a skill is running: the next tick comes a period later
                waits += 1
                time.sleep(max(0.0, config.period - (time.monotonic() - start)))
        return _episode(root, subtrees, ctx, ticks, config)
    except KeyboardInterrupt:
        log.warning("interrupted: stopping the behaviour tree (a running skill is cancelled)")
        raise
    finally:
        root.stop(Status.INVALID)  # terminate() of a running Act cancels its skill
        _release_blackboards(root)


def _episode(
    root: py_trees.behaviour.Behaviour,
    subtrees: list[Explore],
    ctx: Context,
    ticks: int,
    config: ExecutorConfig,
) -> Episode:
    completed = tuple(i for s in subtrees if s.status is Status.SUCCESS for i in s.spec.steps)
    retries = sum(1 for e in ctx.recorder.events if e.status == "backtrack")
    common = dict(
        subtrees=tuple(s.spec.label for s in subtrees),
        completed=completed,
        events=tuple(ctx.recorder.events),
        belief=ctx.belief.snapshot(),
        ticks=ticks,
        retries=retries,
    )
    if root.status is Status.SUCCESS:
        return Episode(ExecStatus.SUCCESS, anomaly=None, **common)  # type: ignore[arg-type]
    failed = next((s for s in subtrees if s.status is Status.FAILURE), None)
    if failed is not None and failed.bb.report is not None:
        return Episode(ExecStatus.ANOMALY, anomaly=failed.bb.report, **common)  # type: ignore[arg-type]
    message = f"stopped after {ticks} ticks (max_ticks={config.max_ticks})"
    return Episode(ExecStatus.BUDGET, anomaly=None, message=message, **common)  # type: ignore[arg-type]


def _release_blackboards(root: py_trees.behaviour.Behaviour) -> None:
    """Drop this run's blackboard keys: the py_trees blackboard is process-global."""
    for node in root.iterate():
        for client in node.blackboards:
            client.unregister(clear=True)


__all__ = [
    "Episode",
    "ExecStatus",
    "ExecutorConfig",
    "OnTick",
    "Tick",
    "build_tree",
    "execute",
    "tick_of",
]
