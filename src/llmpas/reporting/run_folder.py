"""What a run folder holds, read back for the web report: ``loop.json`` (the closed loop's
rounds), each round's episode (``round-I/episode.json``, or the one embedded in ``loop.json``),
the CSubBT XML, ``run.json`` (PyBullet timings), ``media.json`` (which snapshot or camera image
was made at which event of which episode), ``about.json`` (the command that made the run),
``artifacts.json`` (other files a world wrote: a recording, what it holds).

Everything is optional and read tolerantly: a field of the wrong type counts as missing, so a
folder written by an older or newer version (or edited by hand) still gives a page. A file that
exists but is not valid JSON is a :class:`ReportError` naming it (for ``loop.json``) or a note
on the page (for a round's files).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

MAX_JSON_BYTES = 50_000_000  # a larger file is refused
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".gif", ".webp")
DEFERS = "   — defers "  # between a plan step and the streams it leaves to execution


class ReportError(Exception):
    """A run folder that cannot be reported: one line naming the file."""


# --------------------------------------------------------------------------- tolerant access


def get_str(d: Any, key: str) -> str:
    v = d.get(key) if isinstance(d, Mapping) else None
    return v if isinstance(v, str) else "" if v is None or isinstance(v, dict | list) else str(v)


def get_list(d: Any, key: str) -> list[Any]:
    v = d.get(key) if isinstance(d, Mapping) else None
    return v if isinstance(v, list) else []


def get_map(d: Any, key: str) -> Mapping[str, Any]:
    v = d.get(key) if isinstance(d, Mapping) else None
    return v if isinstance(v, Mapping) else {}


def get_float(d: Any, key: str) -> float | None:
    v = d.get(key) if isinstance(d, Mapping) else None
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else None


def get_int(d: Any, key: str) -> int | None:
    v = d.get(key) if isinstance(d, Mapping) else None
    return v if isinstance(v, int) and not isinstance(v, bool) else None


def strings(values: Sequence[Any]) -> tuple[str, ...]:
    return tuple(v if isinstance(v, str) else json.dumps(v) for v in values)


def load_json(path: Path) -> Any:
    """The JSON in ``path`` (None when there is no such file)."""
    try:
        size = path.stat().st_size
    except OSError:
        return None
    if not path.is_file():
        return None
    if size > MAX_JSON_BYTES:
        raise ReportError(f"{path}: {size} bytes, more than the {MAX_JSON_BYTES} a report reads")
    try:
        return json.loads(path.read_bytes().decode("utf-8", errors="replace"))
    except json.JSONDecodeError as e:
        raise ReportError(f"{path}:{e.lineno}:{e.colno}: not valid JSON ({e.msg})") from None
    except (OSError, RecursionError) as e:
        raise ReportError(f"{path}: cannot be read ({type(e).__name__})") from None


# ----------------------------------------------------------------------------------- records


@dataclass(frozen=True)
class Exchange:
    tag: str
    messages: tuple[tuple[str, str], ...]  # (role, content)
    response: str
    model: str
    tokens: int
    latency: float | None


@dataclass(frozen=True)
class Reasoning:
    method: str
    status: str
    goals: tuple[str, ...]
    errors: tuple[str, ...]  # why the last answer was rejected
    notes: tuple[str, ...]  # goals dropped or read differently by the validator
    repairs: int | None
    first_look: str
    exchanges: tuple[Exchange, ...]
    latency: float | None
    # choosing methods: every candidate goal set (goals, score or None, chosen), ranked
    candidates: tuple[tuple[str, float | None, bool], ...] = ()

    @classmethod
    def of(cls, d: Mapping[str, Any]) -> Reasoning:
        exchanges = []
        for e in get_list(d, "exchanges"):
            msgs = tuple(
                (str(m[0]), str(m[1]))
                for m in get_list(e, "messages")
                if isinstance(m, list) and len(m) == 2
            )
            tokens = (get_int(e, "prompt_tokens") or 0) + (get_int(e, "completion_tokens") or 0)
            exchanges.append(
                Exchange(
                    get_str(e, "tag"),
                    msgs,
                    get_str(e, "response"),
                    get_str(e, "model"),
                    tokens,
                    get_float(e, "latency"),
                )
            )
        return cls(
            method=get_str(d, "method"),
            status=get_str(d, "status"),
            goals=strings(get_list(d, "goals")),
            errors=strings(get_list(d, "errors")),
            notes=strings(get_list(d, "notes")),
            repairs=get_int(d, "repairs"),
            first_look=get_str(d, "first_look"),
            exchanges=tuple(exchanges),
            latency=get_float(d, "latency"),
            candidates=tuple(
                (get_str(c, "goals"), get_float(c, "score"), c.get("chosen") is True)
                for c in get_list(d, "candidates")
                if isinstance(c, Mapping)
            ),
        )


@dataclass(frozen=True)
class Media:
    """An image in the folder and, when recorded, the episode and event that made it."""

    path: str  # relative to the run folder, '/'-separated
    kind: str  # snapshot | camera
    label: str
    episode: int | None = None  # ordinal of the executed episode (0: the first one)
    event: int | None = None  # timeline events recorded before it was made


@dataclass(frozen=True)
class Round:
    index: int
    goal: str
    status: str
    plan: tuple[str, ...]
    plan_time: float | None
    episode: Mapping[str, Any] | None
    folder: str  # relative folder of its files ("" for the run folder)
    xml: tuple[str, ...]  # relative paths of its BehaviorTree.CPP files
    reasoning: Reasoning | None
    problems: tuple[str, ...] = ()  # files that could not be read
    note: str = ""  # what the loop said of the round (a sweep's look, a substitution)

    @property
    def timeline(self) -> list[Any]:
        return get_list(self.episode, "timeline")

    @property
    def anomaly(self) -> Mapping[str, Any]:
        return get_map(self.episode, "anomaly")

    @property
    def duration(self) -> float | None:
        ts = [get_float(e, "t") for e in self.timeline]
        return max((t for t in ts if t is not None), default=None)


@dataclass(frozen=True)
class Artifact:
    """A file a world wrote into the run folder (a recording), listed in ``artifacts.json``."""

    file: str  # relative to the run folder
    title: str
    holds: str  # what is in it, in a sentence


@dataclass(frozen=True)
class RunRecord:
    folder: Path
    scenario: str
    loop: bool  # a closed loop (loop.json) or a single episode
    success: bool | None
    message: str
    about: Mapping[str, Any]
    timings: Mapping[str, float]
    llm_time: float | None
    rounds: tuple[Round, ...]
    media: tuple[Media, ...]
    gif: str | None
    raw: tuple[str, ...]
    world_log: tuple[str, ...] = field(default=())
    artifacts: tuple[Artifact, ...] = field(default=())
    basis: str = ""  # what the verdict was judged on: truth, perceived, belief ("": unknown)

    @property
    def task(self) -> str:
        return get_str(self.about, "task") or (self.rounds[0].goal if self.rounds else "")

    def round_of(self, media: Media) -> Round | None:
        """The round an image was made in (None: not recorded)."""
        return next((r for r in self.rounds if media in self.media_of(r)), None)

    def media_of(self, rnd: Round) -> list[Media]:
        """The images made while ``rnd`` executed (those made after the last episode: with
        the last one's)."""
        executed = [r for r in self.rounds if r.episode is not None]
        if rnd not in executed:
            return []
        k = executed.index(rnd)
        last = k == len(executed) - 1
        return [
            m
            for m in self.media
            if m.episode is not None and (m.episode == k or (last and m.episode > k))
        ]


# ------------------------------------------------------------------------------------ reading


def _rel(folder: Path, path: Path) -> str:
    return path.relative_to(folder).as_posix()


def _inside(folder: Path, path: Path) -> bool:
    """``path`` is a regular file inside ``folder`` (no link pointing out of it)."""
    try:
        return path.is_file() and path.resolve().is_relative_to(folder.resolve())
    except OSError:
        return False


def _xml_files(folder: Path, where: Path) -> tuple[str, ...]:
    if not where.is_dir():
        return ()
    files = sorted(p for p in where.glob("*.xml") if _inside(folder, p))
    return tuple(_rel(folder, p) for p in files)


def _plan_lines(plan: Any) -> tuple[tuple[str, ...], float | None]:
    """A round's plan as lines (``loop.json`` keeps either strings or a PlanResult)."""
    if isinstance(plan, list):
        return strings(plan), None
    if not isinstance(plan, Mapping):
        return (), None
    steps = get_list(get_map(plan, "plan"), "steps")
    lines = []
    for s in steps:
        args = " ".join(strings(get_list(s, "args")))
        deferred = strings(get_list(s, "deferred"))
        line = f"({get_str(s, 'action')}{' ' + args if args else ''})"
        lines.append(line + (DEFERS + "; ".join(deferred) if deferred else ""))
    return tuple(lines), get_float(get_map(plan, "stats"), "total_time")


def _round_folder(folder: Path, i: int) -> Path | None:
    for name in (f"round-{i}", f"round{i}"):
        if (folder / name).is_dir():
            return folder / name
    return None


def _read_round(folder: Path, i: int, d: Any) -> Round:
    problems = []
    where = _round_folder(folder, i)
    episode: Any = get_map(d, "episode") or None
    if where is not None:
        try:
            episode = load_json(where / "episode.json") or episode
        except ReportError as e:
            problems.append(str(e))
    status = get_str(d, "status") or get_str(episode, "status") or "no plan"
    if episode is None and get_map(d, "anomaly"):
        episode = {"status": status, "anomaly": get_map(d, "anomaly")}
    plan, plan_time = _plan_lines(d.get("plan") if isinstance(d, Mapping) else None)
    reasoning = get_map(d, "reasoning")
    return Round(
        index=i,
        goal=get_str(d, "goal"),
        status=status,
        plan=plan,
        plan_time=plan_time,
        episode=episode if isinstance(episode, Mapping) else None,
        folder=_rel(folder, where) if where else "",
        xml=_xml_files(folder, where) if where else (),
        reasoning=Reasoning.of(reasoning) if reasoning else None,
        problems=tuple(problems),
        note=get_str(d, "note"),
    )


def _single_round(folder: Path, about: Mapping[str, Any]) -> Round:
    episode = load_json(folder / "episode.json")
    return Round(
        index=0,
        goal=get_str(about, "task"),
        status=get_str(episode, "status") or "no plan",
        plan=strings(get_list(about, "plan")),
        plan_time=get_float(about, "plan_time"),
        episode=episode if isinstance(episode, Mapping) else None,
        folder="",
        xml=_xml_files(folder, folder),
        reasoning=None,
    )


def _media(folder: Path) -> tuple[Media, ...]:
    """From ``media.json`` when present; else every image under snapshots/ and camera/."""
    listed = load_json(folder / "media.json")
    out = []
    if isinstance(listed, list):
        for m in listed:
            rel = get_str(m, "file")
            path = folder / rel
            if rel and not Path(rel).is_absolute() and _inside(folder, path):
                out.append(
                    Media(
                        _rel(folder, path),
                        get_str(m, "kind") or "image",
                        get_str(m, "label"),
                        get_int(m, "episode"),
                        get_int(m, "event"),
                    )
                )
        return tuple(out)
    for kind, sub in (("snapshot", "snapshots"), ("camera", "camera")):
        where = folder / sub
        if where.is_dir():
            for p in sorted(where.iterdir()):
                if p.suffix.lower() in IMAGE_SUFFIXES and _inside(folder, p):
                    out.append(Media(_rel(folder, p), kind, p.stem))
    return tuple(out)


def _raw(folder: Path) -> tuple[str, ...]:
    """The files worth linking: JSON, Markdown, the old reports and the XML (two levels)."""
    keep = (".json", ".md", ".xml", ".html", ".csv")
    found = [
        p
        for pattern in ("*", "*/*")
        for p in folder.glob(pattern)
        if p.suffix.lower() in keep and p.name != "index.html" and _inside(folder, p)
    ]
    return tuple(sorted(_rel(folder, p) for p in found))


def _artifacts(folder: Path) -> tuple[Artifact, ...]:
    """The files ``artifacts.json`` lists (``[{"file", "title", "holds"}]``) that exist in the
    folder; anything else in it is ignored."""
    listed = load_json(folder / "artifacts.json")
    out = []
    for a in listed if isinstance(listed, list) else []:
        name = get_str(a, "file") if isinstance(a, Mapping) else ""
        path = folder / name
        if name and _inside(folder, path) and path.is_file():
            out.append(
                Artifact(_rel(folder, path), get_str(a, "title") or name, get_str(a, "holds"))
            )
    live = folder / "run.mcap"
    if _inside(folder, live) and all(a.file != "run.mcap" for a in out):
        out.insert(0, Artifact("run.mcap", "Foxglove MCAP", RUN_MCAP_HOLDS))
    return tuple(out)


# what every run's run.mcap holds (llmpas.reporting.live; docs/live.md)
RUN_MCAP_HOLDS = (
    "the loop's channels, as the live view shows them: the scene (believed and true), the "
    "robot's frames, the behaviour tree per tick, the plan, each anomaly, each LLM prompt, "
    "answer and verdict, the belief and the loop's status; open it in Foxglove with "
    "docs/foxglove-layout.json"
)


def read_run(folder: str | Path) -> RunRecord:
    """Read a run folder (``llmpas run/execute ... --out``) for the report."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ReportError(f"{folder}: no such folder")
    about = load_json(folder / "about.json")
    about = about if isinstance(about, Mapping) else {}
    loop = load_json(folder / "loop.json")
    run = load_json(folder / "run.json")
    if loop is None and run is None and not (folder / "episode.json").is_file():
        raise ReportError(f"{folder}: no loop.json, run.json or episode.json: not a run folder")
    if isinstance(loop, Mapping):
        rounds = tuple(_read_round(folder, i, r) for i, r in enumerate(get_list(loop, "rounds")))
    else:
        rounds = (_single_round(folder, about),)
    source = loop if isinstance(loop, Mapping) else run if isinstance(run, Mapping) else {}
    success: Any = source.get("success", source.get("achieved")) if source else None
    if success is None and not isinstance(loop, Mapping) and rounds[0].episode is not None:
        success = rounds[0].status == "success"
    timings = {
        k: float(v)
        for k, v in {**get_map(run, "timings"), **get_map(loop, "timings")}.items()
        if isinstance(v, int | float)
    }
    gif = folder / "episode.gif"
    return RunRecord(
        folder=folder,
        scenario=get_str(loop, "scenario")
        or get_str(run, "scenario")
        or get_str(about, "scenario")
        or folder.resolve().name,
        loop=isinstance(loop, Mapping),
        success=success if isinstance(success, bool) else None,
        basis=get_str(loop, "verdict_basis"),
        message=get_str(loop, "message") or get_str(about, "message"),
        about=about,
        timings=timings,
        llm_time=get_float(loop, "llm_time"),
        rounds=rounds,
        media=_media(folder),
        gif="episode.gif" if _inside(folder, gif) else None,
        raw=_raw(folder),
        world_log=strings(get_list(run, "world_log")),
        artifacts=_artifacts(folder),
    )


__all__ = [
    "Artifact",
    "Exchange",
    "Media",
    "Reasoning",
    "ReportError",
    "Round",
    "RunRecord",
    "read_run",
]
