"""The loop in Foxglove: a live WebSocket view (``llmpas run --live``) and ``run.mcap``, the same
channels in every world, written by the ``foxglove-sdk`` (its MCAP sink and WebSocket server).

:class:`FoxgloveSink` is an :class:`~llmpas.system.observe.Observer`: the loop tells it of every
plan, tick, round, consultation and record, and it logs them on its own
:class:`foxglove.Context` (no process-wide state) to the sinks it opened:

=========================  ===============================  ==================================
topic                      schema                           what
=========================  ===============================  ==================================
``/llmpas/scene``          ``foxglove.SceneUpdate``         places, objects where believed
``/llmpas/scene/truth``    ``foxglove.SceneUpdate``         objects where they truly are
``/llmpas/tf``             ``foxglove.FrameTransforms``     the robot's frames (where known)
``/llmpas/tree``           ``llmpas.Tick`` (JSON)           every node's status, per tick
``/llmpas/plan``           ``llmpas.Plan`` (JSON)           the plan, the steps running
``/llmpas/anomaly``        ``llmpas.Anomaly`` (JSON)        each anomaly report
``/llmpas/llm``            ``llmpas.LLM`` (JSON)            each prompt, answer and verdict
``/llmpas/belief``         ``llmpas.Belief`` (JSON)         the believed facts when they change
``/llmpas/loop``           ``llmpas.Loop`` (JSON)           the round and the loop's status
``/llmpas/log``            ``foxglove.Log``                 one line per step, for a log panel
=========================  ===============================  ==================================

The scene (and the belief read with it) is throttled to one update per ``scene_period`` seconds
while a tree ticks, and sent at every round's start and end; a tick that changes no node's
status (one that only polls a running skill) is counted in the next tick sent (``folded``);
nothing else is ever dropped.
A world whose session is a :class:`~llmpas.worlds.api.SceneGeometry` is drawn in metres; any
other is drawn from its search model's places and the believed (and true) ``location`` facts.
"""

from __future__ import annotations

import ipaddress
import json
import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import foxglove
from foxglove import channels as fc
from foxglove import messages as fm

from llmpas.execution.executor import Tick
from llmpas.files import atomic_write
from llmpas.language.logic import Atom
from llmpas.planning import PlanResult
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.methods import Proposal
from llmpas.system.records import LoopResult, Round
from llmpas.worlds.api import Pose3, SceneGeometry, SceneView, Session, Shape, TrueFacts

log = logging.getLogger(__name__)

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
SCENE_PERIOD = 0.2  # seconds between scene updates while a tree ticks
LAYOUT = "foxglove-layout.json"  # written beside run.mcap (and shipped in docs/)
TOPICS = (
    "/llmpas/scene",
    "/llmpas/scene/truth",
    "/llmpas/tf",
    "/llmpas/tree",
    "/llmpas/plan",
    "/llmpas/anomaly",
    "/llmpas/llm",
    "/llmpas/belief",
    "/llmpas/loop",
    "/llmpas/log",
)


class LiveError(ValueError):
    """A bad ``--live`` value, or a server that cannot listen there (one line)."""


@dataclass(frozen=True)
class LiveAddress:
    """Where the live server listens: an IP address (or ``localhost``) and a port (0: any free
    one)."""

    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT

    def __post_init__(self) -> None:
        if not 0 <= self.port <= 65535:
            raise LiveError(f"--live {self.host}:{self.port}: the port must be 0..65535")
        if self.host != "localhost":
            try:
                ipaddress.ip_address(self.host)
            except ValueError:
                raise LiveError(
                    f"--live {self.host}:{self.port}: the host must be an IP address or localhost"
                ) from None

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"


def parse_address(text: str) -> LiveAddress:
    """``HOST:PORT``, ``:PORT``, ``PORT``, ``HOST`` or ``[IPV6]:PORT`` (an empty host:
    127.0.0.1, an empty port: 8765); LiveError naming the value otherwise."""
    value = text.strip()
    host, port = value, ""
    if value.startswith("["):
        end = value.find("]")
        if end < 0 or (value[end + 1 :] and not value[end + 1 :].startswith(":")):
            raise LiveError(f"--live {text!r}: expected [IPV6]:PORT")
        host, port = value[1:end], value[end + 2 :]
    elif value.isdigit():
        host, port = "", value
    elif value.count(":") == 1:
        host, port = value.split(":")
    if not port.strip():
        number = DEFAULT_PORT
    elif port.isdigit():
        number = int(port)
    else:
        raise LiveError(f"--live {text!r}: the port {port!r} is not a number (expected HOST:PORT)")
    return LiveAddress(host or DEFAULT_HOST, number)


# ------------------------------------------------------------------------------ schemas


def _obj(properties: Mapping[str, Any], required: Sequence[str] = ()) -> dict[str, Any]:
    return {"type": "object", "properties": dict(properties), "required": list(required)}


_STR = {"type": "string"}
_INT = {"type": "integer"}
_STRS = {"type": "array", "items": _STR}


def json_schemas() -> dict[str, tuple[str, dict[str, Any]]]:
    """Topic -> (schema name, JSON schema) of the JSON channels (a new dict per call)."""
    node = _obj({"name": _STR, "status": _STR, "depth": _INT}, ["name", "status", "depth"])
    return {
        "/llmpas/tree": (
            "llmpas.Tick",
            _obj(
                {
                    "round": _INT,
                    "tick": _INT,
                    "status": _STR,
                    "steps": {"type": "array", "items": _INT},
                    "nodes": {"type": "array", "items": node},
                    "folded": {
                        "type": "integer",
                        "description": "ticks before this one that changed nothing (not sent)",
                    },
                },
                ["round", "tick", "status", "nodes"],
            ),
        ),
        "/llmpas/plan": (
            "llmpas.Plan",
            _obj(
                {
                    "round": _INT,
                    "goal": _STR,
                    "status": _STR,
                    "steps": _STRS,
                    "current": {"type": "array", "items": _INT},
                    "current_text": _STRS,
                },
                ["round", "goal", "status", "steps", "current"],
            ),
        ),
        "/llmpas/anomaly": (
            "llmpas.Anomaly",
            _obj(
                {"round": _INT, "text": _STR, "report": {"type": "object"}},
                ["round", "text", "report"],
            ),
        ),
        "/llmpas/llm": (
            "llmpas.LLM",
            _obj(
                {
                    "round": _INT,
                    "kind": {"type": "string", "enum": ["prompt", "answer", "verdict"]},
                    "tag": _STR,
                    "method": _STR,
                    "messages": {"type": "array", "items": _obj({"role": _STR, "content": _STR})},
                    "text": _STR,
                    "model": _STR,
                    "status": _STR,
                    "goals": _STRS,
                    "errors": _STRS,
                    "notes": _STRS,
                    "repairs": _INT,
                },
                ["round", "kind"],
            ),
        ),
        "/llmpas/belief": (
            "llmpas.Belief",
            _obj({"round": _INT, "facts": _STRS}, ["round", "facts"]),
        ),
        "/llmpas/loop": (
            "llmpas.Loop",
            _obj(
                {
                    "scenario": _STR,
                    "round": _INT,
                    "status": _STR,
                    "message": _STR,
                    "success": {"type": "boolean"},
                    "llm_calls": _INT,
                },
                ["scenario", "round", "status", "message"],
            ),
        ),
    }


# ------------------------------------------------------------------------------ the scene


def scene_of(session: Session) -> SceneView:
    """The scene of ``session`` now: its own (a :class:`SceneGeometry`), else drawn from the
    search model's places in a row and the objects on them (believed, and true where the world
    has a truth) stacked above their place."""
    if isinstance(session, SceneGeometry):
        return session.scene_view()
    search = session.search
    places = list(dict.fromkeys(search.places()))
    where = {p: (2.0 * i, 0.0) for i, p in enumerate(places)}
    shapes = [
        Shape(p, "place", (x, y, 0.05), (1.6, 1.0, 0.1), rgba=_PLACE) for p, (x, y) in where.items()
    ]
    believed = _stacked(session.context.belief.facts, search.location, where, _BELIEVED)
    truth: list[Shape] = []
    if isinstance(session, TrueFacts):
        truth = _stacked(session.true_facts(), search.location, where, _TRUE)
    return SceneView(tuple(shapes + believed), tuple(truth))


_PLACE = (0.55, 0.45, 0.35, 1.0)
_BELIEVED = (0.2, 0.5, 0.95, 1.0)
_TRUE = (0.95, 0.55, 0.1, 0.45)


def _stacked(
    facts: Iterable[Atom],
    location: str,
    where: Mapping[str, tuple[float, float]],
    rgba: tuple[float, float, float, float],
) -> list[Shape]:
    """Objects on places (``(location O P)``) as small boxes in a row on their place."""
    count: dict[str, int] = {}
    out = []
    for a in sorted(facts, key=str):
        if a.predicate != location or len(a.args) < 2 or a.args[1] not in where:
            continue
        obj, place = a.args[0], a.args[1]
        k = count[place] = count.get(place, -1) + 1
        x, y = where[place]
        xyz = (x - 0.6 + 0.3 * (k % 5), y - 0.3 + 0.3 * (k // 5), 0.2)
        out.append(Shape(obj, "object", xyz, (0.16, 0.16, 0.16), rgba=rgba))
    return out


def _quat(yaw: float) -> fm.Quaternion:
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _vec(v: Sequence[float]) -> fm.Vector3:
    return fm.Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def _colour(rgba: Sequence[float]) -> fm.Color:
    return fm.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])


def _entity(layer: str, s: Shape) -> fm.SceneEntity:
    pose = fm.Pose(position=_vec(s.xyz), orientation=_quat(s.yaw))
    label_at = (s.xyz[0], s.xyz[1], s.xyz[2] + s.size[2] / 2 + 0.08)
    label = fm.TextPrimitive(
        pose=fm.Pose(position=_vec(label_at), orientation=_quat(0.0)),
        billboard=True,
        font_size=14.0 if s.kind == "object" else 16.0,
        scale_invariant=True,
        color=_colour((1.0, 1.0, 1.0, 1.0)),
        text=s.name,
    )
    cube = fm.CubePrimitive(pose=pose, size=_vec(s.size), color=_colour(s.rgba))
    return fm.SceneEntity(
        frame_id="world",
        id=f"{layer}/{s.kind}/{s.name}",
        metadata=[fm.KeyValuePair(key="kind", value=s.kind)],
        cubes=[cube],
        texts=[label],
    )


def scene_update(layer: str, shapes: Sequence[Shape]) -> fm.SceneUpdate:
    """A full replacement of a layer: every entity deleted, then the shapes."""
    clear = fm.SceneEntityDeletion(type=fm.SceneEntityDeletionType.All)
    return fm.SceneUpdate(deletions=[clear], entities=[_entity(layer, s) for s in shapes])


def transforms(frames: Sequence[Pose3]) -> fm.FrameTransforms:
    return fm.FrameTransforms(
        transforms=[
            fm.FrameTransform(
                parent_frame_id=f.parent,
                child_frame_id=f.name,
                translation=_vec(f.xyz),
                rotation=fm.Quaternion(
                    x=f.quaternion[0], y=f.quaternion[1], z=f.quaternion[2], w=f.quaternion[3]
                ),
            )
            for f in frames
        ]
    )


# ------------------------------------------------------------------------------ the layout


def layout() -> str:
    """The Foxglove layout for these channels (JSON, built with ``foxglove.layouts``): the 3-D
    scene (believed and true layers) beside the plan and the tree, the LLM's exchanges and the
    anomaly in tabs, the loop's status and the log below."""
    import foxglove.layouts as fl

    def raw(topic: str, title: str) -> Any:
        return fl.RawMessagesPanel(
            title=title, config=fl.RawMessagesConfig(topic_path=topic, expansion="all")
        )

    def split(direction: str, *items: tuple[float, Any]) -> Any:
        return fl.SplitContainer(
            direction=direction,  # type: ignore[arg-type]
            items=[fl.SplitItem(proportion=w, content=c) for w, c in items],
        )

    scene = fl.ThreeDeePanel(
        title="scene: believed (solid) and true (faint)",
        config=fl.ThreeDeeConfig(
            follow_tf="world",
            topics={
                "/llmpas/scene": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/llmpas/scene/truth": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
            },
            layers={"grid": fl.BaseRendererGridLayerSettings(visible=True, frame_id="world")},
        ),
    )
    tabs = fl.TabContainer(
        tabs=[
            fl.TabItem(title="LLM", content=raw("/llmpas/llm", "prompts, answers, verdicts")),
            fl.TabItem(title="anomaly", content=raw("/llmpas/anomaly", "anomaly reports")),
            fl.TabItem(title="belief", content=raw("/llmpas/belief.facts", "believed facts")),
        ]
    )
    status = fl.StateTransitionsPanel(
        title="loop",
        config=fl.StateTransitionsConfig(
            paths=[
                fl.StateTransitionsSeries(value="/llmpas/loop.status", label="loop"),
                fl.StateTransitionsSeries(value="/llmpas/tree.status", label="tree"),
                fl.StateTransitionsSeries(value="/llmpas/plan.goal", label="goal"),
            ]
        ),
    )
    log = fl.LogPanel(title="log", config=fl.LogConfig(topic_to_render="/llmpas/log"))
    right = split(
        "column",
        (1.0, raw("/llmpas/plan", "plan (current: the steps running)")),
        (1.0, raw("/llmpas/tree", "behaviour tree")),
        (1.2, tabs),
    )
    top = split("row", (1.4, scene), (1.0, right))
    content = split("column", (3.0, top), (1.0, split("row", (1.0, status), (1.0, log))))
    return fl.Layout(content=content).to_json()


# ------------------------------------------------------------------------------ the sink


class _Subscribed(foxglove.ServerListener):
    """Sets ``event`` when a viewer subscribes to a channel."""

    def __init__(self, event: threading.Event) -> None:
        self.event = event

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.event.set()


class FoxgloveSink:
    """The loop's channels logged to ``run.mcap`` (``mcap``) and/or a live server (``live``):
    an :class:`~llmpas.system.observe.Observer`. Use it as a context manager: it opens its
    sinks on entry (a server that cannot listen: :class:`LiveError`) and closes them on exit,
    the MCAP file complete even when the run stopped on an error or an interrupt."""

    def __init__(
        self,
        mcap: str | Path | None = None,
        live: LiveAddress | None = None,
        scene_period: float = SCENE_PERIOD,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if not scene_period >= 0.0:
            raise ValueError(f"scene_period must be >= 0 seconds, got {scene_period}")
        self.mcap_path = None if mcap is None else Path(mcap)
        self.address = live
        self.scene_period = scene_period
        self.clock = clock
        self.context = foxglove.Context()
        self.writer: Any = None
        self.server: Any = None
        self.subscribed = threading.Event()
        self.session: Session | None = None
        self.last_scene = -math.inf
        self.facts: frozenset[str] | None = None
        self.running: tuple[int, ...] | None = None
        self.plans: dict[int, dict[str, Any]] = {}
        self.round = 0
        self.last_tick: tuple[Any, ...] | None = None  # the last tree sent
        self.folded = 0  # ticks since then that changed nothing
        self.told: dict[str, int] = {}  # requests answered live, by key, not yet in a proposal
        self._channels()

    def _channels(self) -> None:
        ctx = self.context
        self.scene = fc.SceneUpdateChannel("/llmpas/scene", context=ctx)
        self.truth = fc.SceneUpdateChannel("/llmpas/scene/truth", context=ctx)
        self.tf = fc.FrameTransformsChannel("/llmpas/tf", context=ctx)
        self.log_channel = fc.LogChannel("/llmpas/log", context=ctx)
        self.json: dict[str, foxglove.Channel] = {}
        for topic, (name, schema) in json_schemas().items():
            data = json.dumps(schema).encode()
            self.json[topic] = foxglove.Channel(
                topic,
                schema=foxglove.Schema(name=name, encoding="jsonschema", data=data),
                message_encoding="json",
                context=ctx,
            )

    # -------------------------------------------------------------- opening and closing

    def __enter__(self) -> FoxgloveSink:
        if self.mcap_path is not None:
            self.mcap_path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(self.mcap_path.parent / LAYOUT, layout())
            self.writer = foxglove.open_mcap(
                self.mcap_path, allow_overwrite=True, context=self.context
            )
        if self.address is not None:
            try:
                self.server = foxglove.start_server(
                    name="llmpas",
                    host=self.address.host,
                    port=self.address.port,
                    context=self.context,
                    server_listener=_Subscribed(self.subscribed),
                )
            except RuntimeError as e:
                self.close()
                reason = str(e).removeprefix("FoxgloveError: ")
                raise LiveError(
                    f"--live {self.address.host}:{self.address.port}: {reason}"
                ) from None
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def url(self) -> str:
        """Where a viewer connects (the port the server got, when 0 was asked)."""
        if self.server is None or self.address is None:
            return ""
        return LiveAddress(self.address.host, int(self.server.port)).url

    def wait_for_viewer(self, seconds: float | None = None) -> bool:
        """Block until a viewer subscribes to a channel (``seconds``: at most that long), then
        let it subscribe to the rest; Ctrl-C ends the wait."""
        if self.server is None:
            return False
        end = math.inf if seconds is None else time.monotonic() + seconds
        while not self.subscribed.wait(0.1):
            if time.monotonic() >= end:
                return False
        time.sleep(0.5)  # a viewer subscribes channel by channel
        return True

    def close(self) -> None:
        if self.server is not None:
            self.server.stop()
            self.server = None
        if self.writer is not None:
            self.writer.close()
            self.writer = None

    # -------------------------------------------------------------- logging

    def _json(self, topic: str, message: Mapping[str, Any]) -> None:
        self.json[topic].log(json.dumps(message).encode())

    def _line(self, text: str, level: Any = fm.LogLevel.Info) -> None:
        self.log_channel.log(fm.Log(level=level, message=text, name="llmpas"))

    def _scene(self, force: bool = False) -> None:
        now = self.clock()
        if self.session is None or (not force and now - self.last_scene < self.scene_period):
            return
        self.last_scene = now
        view = scene_of(self.session)
        self.scene.log(scene_update("believed", view.believed))
        if view.truth:
            self.truth.log(scene_update("truth", view.truth))
        if view.frames:
            self.tf.log(transforms(view.frames))
        self._belief()

    def _belief(self) -> None:
        if self.session is None:
            return
        facts = frozenset(map(str, self.session.context.belief.facts))
        if facts != self.facts:
            self.facts = facts
            self._json("/llmpas/belief", {"round": self.round, "facts": sorted(facts)})

    # -------------------------------------------------------------- the observer

    def started(self, session: Session) -> None:
        self.session = session
        self._line(f"{session.name}: the task {session.task}")
        self._scene(force=True)

    def planned(self, index: int, goal: str, plan: PlanResult) -> None:
        self.round, self.running = index, None
        steps = [str(s) for s in plan.plan.steps] if plan.plan is not None else []
        self.plans[index] = {
            "round": index,
            "goal": goal,
            "status": plan.status.value,
            "steps": steps,
            "current": [],
            "current_text": [],
        }
        self._json("/llmpas/plan", self.plans[index])
        self._line(f"round {index}: {goal}: {plan.status.value}, {len(steps)} steps")
        self._scene(force=True)

    def ticked(self, index: int, tick: Tick) -> None:
        same = (index, tick.nodes, tick.steps, tick.status)
        if same == self.last_tick:  # a tick that only polled a running skill: folded
            self.folded += 1
        else:
            self.last_tick = same
            message = {"round": index, **tick.to_json(), "folded": self.folded}
            self._json("/llmpas/tree", message)
            self.folded = 0
        if tick.steps != self.running and index in self.plans:
            self.running = tick.steps
            plan = self.plans[index]
            text = [plan["steps"][k] for k in tick.steps if 0 <= k < len(plan["steps"])]
            self._json("/llmpas/plan", {**plan, "current": list(tick.steps), "current_text": text})
        self._scene()

    def executed(self, index: int, rnd: Round) -> None:
        ep = rnd.episode
        if ep is not None and ep.anomaly is not None:
            text = ep.anomaly.describe()
            report = {"round": index, "text": text, "report": ep.anomaly.to_json()}
            self._json("/llmpas/anomaly", report)
            self._line(f"round {index}: anomaly: {text}", fm.LogLevel.Warning)
        status = ep.status.value if ep is not None else "no-plan"
        self._line(f"round {index}: executed: {status}")
        self._scene(force=True)

    def prompted(self, index: int, request: Request) -> None:
        messages = [{"role": m.role, "content": m.content} for m in request.messages]
        prompt = {"round": index, "kind": "prompt", "tag": request.tag, "messages": messages}
        self._json("/llmpas/llm", prompt)
        self._line(f"round {index}: asked the LLM ({request.tag})")

    def replied(self, index: int, request: Request, response: Response) -> None:
        key = request.key()
        self.told[key] = self.told.get(key, 0) + 1
        answer = {"kind": "answer", "text": response.text, "model": response.model}
        self._json("/llmpas/llm", {"round": index, "tag": request.tag, **answer})

    def answered(self, index: int, proposal: Proposal) -> None:
        p = proposal
        for e in p.exchanges:  # each exchange once: those not told as they happened, now
            key = e.request.key()
            if self.told.get(key, 0) > 0:
                self.told[key] -= 1
                continue
            self.prompted(index, e.request)
            answer = {"kind": "answer", "text": e.response.text, "model": e.response.model}
            self._json("/llmpas/llm", {"round": index, "tag": e.request.tag, **answer})
        self.told.clear()
        verdict = {
            "round": index,
            "kind": "verdict",
            "method": p.method,
            "status": p.parse.status.value,
            "goals": [str(g) for g in p.goals],
            "errors": list(p.parse.errors),
            "notes": list(p.parse.notes),
            "repairs": p.repairs,
        }
        self._json("/llmpas/llm", verdict)
        goals = " ".join(str(g) for g in p.goals) or "none"
        self._line(f"round {index}: {p.method} ({p.parse.status.value}): {goals}")

    def recorded(self, result: LoopResult) -> None:
        status = result.status.value if result.status is not None else ""
        message = {
            "scenario": result.scenario,
            "round": max(0, len(result.rounds) - 1),
            "status": status,
            "message": result.message,
            "success": result.success,
            "llm_calls": result.llm_calls,
        }
        self._json("/llmpas/loop", message)
        self._belief()


__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "LAYOUT",
    "TOPICS",
    "FoxgloveSink",
    "LiveAddress",
    "LiveError",
    "json_schemas",
    "layout",
    "parse_address",
    "scene_of",
    "scene_update",
    "transforms",
]
