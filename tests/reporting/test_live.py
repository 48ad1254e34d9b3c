"""The loop in Foxglove (llmpas.reporting.live): a household run watched live over the Foxglove
WebSocket protocol by a client written here, the main job's ``run.mcap`` read back with
``mcap``, no listening socket without ``--live``, and a bad ``--live`` as one line."""

from __future__ import annotations

import json
import math
import os
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from llmpas.cli import main
from llmpas.reporting.live import (
    TOPICS,
    FoxgloveSink,
    LiveAddress,
    LiveError,
    parse_address,
    scene_of,
)

mcap_reader = pytest.importorskip("mcap.reader")

ROOT = Path(__file__).resolve().parents[2]
HOUSEHOLD = "object-loss-table"  # the cube is not where the robot believed: one anomaly, one LLM
WATCHED = ("/llmpas/scene", "/llmpas/tree", "/llmpas/plan", "/llmpas/anomaly", "/llmpas/llm")
SCHEMAS = {
    "/llmpas/scene": ("foxglove.SceneUpdate", "protobuf"),
    "/llmpas/scene/truth": ("foxglove.SceneUpdate", "protobuf"),
    "/llmpas/tf": ("foxglove.FrameTransforms", "protobuf"),
    "/llmpas/log": ("foxglove.Log", "protobuf"),
    "/llmpas/tree": ("llmpas.Tick", "jsonschema"),
    "/llmpas/plan": ("llmpas.Plan", "jsonschema"),
    "/llmpas/anomaly": ("llmpas.Anomaly", "jsonschema"),
    "/llmpas/llm": ("llmpas.LLM", "jsonschema"),
    "/llmpas/belief": ("llmpas.Belief", "jsonschema"),
    "/llmpas/loop": ("llmpas.Loop", "jsonschema"),
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# ----------------------------------------------------------------------- the live view


# the Foxglove WebSocket protocol; foxglove-sdk 0.30 servers speak it as "foxglove.sdk.v1" (the
# same operations and binary framing), older servers and the app as "foxglove.websocket.v1"
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")


def _connect(port: int, proc: subprocess.Popen[bytes]) -> Any:
    """A Foxglove WebSocket client on the run's server, once it listens (the run waits for a
    viewer: ``--live-wait``); a server that refuses the handshake fails the test at once."""
    from websockets.sync.client import connect

    for _ in range(1500):  # importing and opening the world takes a while on a busy machine
        if proc.poll() is not None:
            pytest.fail(f"the run ended before a viewer connected: {proc.stderr.read()!r}")  # type: ignore[union-attr]
        try:
            return connect(
                f"ws://127.0.0.1:{port}",
                subprotocols=list(SUBPROTOCOLS),  # type: ignore[arg-type]
                open_timeout=30,
                max_size=None,
            )
        except ConnectionRefusedError:
            time.sleep(0.2)
    pytest.fail("the run's server never listened")


Advertised = dict[int, dict[str, Any]]


def _watch(port: int, proc: subprocess.Popen[bytes]) -> tuple[Advertised, dict[str, list[bytes]]]:
    """The channels the server advertised (by id) and the payloads received per topic, until
    the run ends and closes the connection."""
    from websockets.exceptions import ConnectionClosed

    channels: dict[int, dict[str, Any]] = {}
    subscribed: dict[int, str] = {}
    received: dict[str, list[bytes]] = {}
    with _connect(port, proc) as ws:
        assert ws.subprotocol in SUBPROTOCOLS
        try:
            while True:
                frame = ws.recv(timeout=300)
                if isinstance(frame, str):
                    op = json.loads(frame)
                    if op.get("op") == "advertise":
                        fresh = [c for c in op["channels"] if c["id"] not in channels]
                        channels.update({c["id"]: c for c in fresh})
                        subs = [{"id": 100 + c["id"], "channelId": c["id"]} for c in fresh]
                        subscribed.update({100 + c["id"]: c["topic"] for c in fresh})
                        if subs:
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                    continue
                assert frame[0] == 1, "a binary frame of the server is a message data frame"
                sub, _log_time = struct.unpack_from("<IQ", frame, 1)
                received.setdefault(subscribed[sub], []).append(bytes(frame[13:]))
        except ConnectionClosed:
            pass
    return channels, received


def test_a_household_run_is_watched_live_over_the_foxglove_protocol(tmp_path: Path) -> None:
    port = _free_port()
    argv = [sys.executable, "-m", "llmpas.cli", "run", HOUSEHOLD, "--llm", "oracle"]
    argv += ["--live", f"127.0.0.1:{port}", "--live-wait"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        channels, received = _watch(port, proc)
        out, err = proc.communicate(timeout=300)
    finally:
        proc.kill()
    assert proc.returncode == 0, err.decode()
    assert f"ws://127.0.0.1:{port}" in out.decode()  # the line that says where to connect
    advertised = {c["topic"]: c for c in channels.values()}
    assert set(advertised) == set(TOPICS)
    for topic, (name, _encoding) in SCHEMAS.items():
        assert advertised[topic]["schemaName"] == name
    for topic in WATCHED:
        assert received.get(topic), f"no message on {topic}"
    anomaly = json.loads(received["/llmpas/anomaly"][0])
    assert "cube" in anomaly["text"]
    kinds = [json.loads(m)["kind"] for m in received["/llmpas/llm"]]
    assert "prompt" in kinds and "answer" in kinds and kinds[-1] == "verdict"
    tick = json.loads(received["/llmpas/tree"][0])
    assert tick["nodes"][0]["name"] == "plan" and tick["nodes"][0]["depth"] == 0


# ----------------------------------------------------------------------- run.mcap


def _messages(path: Path) -> Iterator[tuple[Any, Any, Any]]:
    with path.open("rb") as f:
        yield from mcap_reader.make_reader(f).iter_messages(log_time_order=False)


def test_the_main_jobs_run_mcap_holds_the_loop(main_job: Path) -> None:
    path = main_job / "run.mcap"
    with path.open("rb") as f:
        summary = mcap_reader.make_reader(f).get_summary()
    assert summary is not None
    found = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values()}
    assert set(found) == set(TOPICS)
    for topic, (name, encoding) in SCHEMAS.items():
        assert (found[topic].name, found[topic].encoding) == (name, encoding)
        assert found[topic].data, f"{topic}: an empty schema"
    jsons = {t for t, (_, e) in SCHEMAS.items() if e == "jsonschema"}
    times, by_topic = [], {}
    for _schema, channel, message in _messages(path):  # in the order written
        times.append(message.log_time)
        data = json.loads(message.data) if channel.topic in jsons else message.data
        by_topic.setdefault(channel.topic, []).append(data)
    assert times == sorted(times), "messages are written in time order"
    for topic in (*WATCHED, "/llmpas/tf", "/llmpas/scene/truth", "/llmpas/belief"):
        assert by_topic.get(topic), f"no message on {topic}"
    # the anomaly and every prompt and answer of the run, as loop.json has them
    loop = json.loads((main_job / "loop.json").read_text())
    anomalies = [r["anomaly"] for r in loop["rounds"] if r["anomaly"]]
    assert [m["report"] for m in by_topic["/llmpas/anomaly"]] == anomalies
    exchanges = [
        (i, e)
        for i, r in enumerate(loop["rounds"])
        for e in r.get("reasoning", {}).get("exchanges", [])
    ]
    assert exchanges, "the main job asks the LLM"
    llm = by_topic["/llmpas/llm"]
    prompts = [(m["round"], m["tag"], [[x["role"], x["content"]] for x in m["messages"]])
               for m in llm if m["kind"] == "prompt"]  # fmt: skip
    answers = [(m["round"], m["tag"], m["text"]) for m in llm if m["kind"] == "answer"]
    assert prompts == [(i, e["tag"], e["messages"]) for i, e in exchanges]
    assert answers == [(i, e["tag"], e["response"]) for i, e in exchanges]
    verdicts = [m for m in llm if m["kind"] == "verdict"]
    reasoned = [r["reasoning"] for r in loop["rounds"] if "reasoning" in r]
    assert [v["goals"] for v in verdicts] == [r["goals"] for r in reasoned]
    assert by_topic["/llmpas/loop"][-1]["status"] == loop["status"]
    page = (main_job / "index.html").read_text()
    assert 'href="run.mcap"' in page


# ----------------------------------------------------------------------- no socket when off


def _listening() -> set[int]:
    """Inodes of this process's listening TCP sockets (Linux /proc)."""
    mine = set()
    for fd in Path("/proc/self/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            mine.add(int(target[8:-1]))
    listening = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not Path(table).exists():
            continue
        for row in Path(table).read_text().splitlines()[1:]:
            cols = row.split()
            if cols[3] == "0A":  # LISTEN
                listening.add(int(cols[9]))
    return mine & listening


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs Linux /proc")
def test_only_live_listens(tmp_path: Path) -> None:
    before = _listening()
    with FoxgloveSink(tmp_path / "run.mcap"):  # what every run with --out opens
        assert _listening() == before
    with FoxgloveSink(None, LiveAddress("127.0.0.1", 0)) as live:  # the check can fail
        assert len(_listening() - before) == 1
        assert live.url.startswith("ws://127.0.0.1:")
    assert _listening() == before


def test_a_run_without_live_starts_no_server(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import foxglove

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a server was started without --live")

    monkeypatch.setattr(foxglove, "start_server", refuse)
    before = _listening() if Path("/proc/self/fd").is_dir() else set()
    seen: list[set[int]] = []
    import importlib

    entry = importlib.import_module("llmpas.system.entry_points")
    save = entry.save_records

    def spy(result: Any, folder: Any) -> Any:  # every step of the run: nothing listens
        seen.append(_listening() if Path("/proc/self/fd").is_dir() else set())
        return save(result, folder)

    monkeypatch.setattr(entry, "save_records", spy)
    assert main(["run", HOUSEHOLD, "--llm", "oracle", "--out", str(tmp_path / "run")]) == 0
    assert seen and all(s == before for s in seen)
    assert (tmp_path / "run" / "run.mcap").stat().st_size > 0


# ----------------------------------------------------------------------- bad --live


@pytest.mark.parametrize(
    "value", ["nonsense", "127.0.0.1:http", "127.0.0.1:70000", "example.com:8765", "[::1"]
)
def test_a_malformed_live_address_is_one_line(
    value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", HOUSEHOLD, "--llm", "oracle", "--live", value]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --live") and "\n" not in err
    assert "Traceback" not in err


def test_a_port_in_use_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = tmp_path / "run"
        code = main(["run", HOUSEHOLD, "--llm", "oracle", "--live", f"127.0.0.1:{port}",
                     "--out", str(out)])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert code == 6
    assert err.startswith(f"error: --live 127.0.0.1:{port}:") and "in use" in err
    assert "\n" not in err
    assert not (out / "loop.json").exists()  # nothing ran


def test_live_wait_needs_live(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", HOUSEHOLD, "--llm", "oracle", "--live-wait"]) == 2
    assert "--live-wait needs --live" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "host", "port"),
    [
        ("127.0.0.1:8765", "127.0.0.1", 8765),
        (":9000", "127.0.0.1", 9000),
        ("9000", "127.0.0.1", 9000),
        ("0.0.0.0", "0.0.0.0", 8765),
        ("[::1]:9001", "::1", 9001),
        ("localhost:0", "localhost", 0),
    ],
)
def test_live_addresses(text: str, host: str, port: int) -> None:
    assert parse_address(text) == LiveAddress(host, port)


def test_a_live_address_outside_the_ports_is_refused() -> None:
    with pytest.raises(LiveError, match=r"0\.\.65535"):
        LiveAddress("127.0.0.1", 65536)


# ----------------------------------------------------------------------- any world


def test_a_world_without_geometry_is_drawn_from_its_places_and_facts() -> None:
    """A session with no scene of its own: its places in a row, the believed objects on them,
    and where the world has a truth, the true ones in the second layer."""
    from llmpas.system.catalog import load_world
    from llmpas.worlds.api import RunOptions, SceneGeometry, TrueFacts

    with load_world("household").open(HOUSEHOLD, RunOptions()) as session:
        assert not isinstance(session, SceneGeometry)
        view = scene_of(session)
        places = {s.name for s in view.believed if s.kind == "place"}
        assert places == set(session.search.places())
        believed = {s.name for s in view.believed if s.kind == "object"}
        location = session.search.location
        on = {a.args[0] for a in session.context.belief.facts if a.predicate == location}
        assert believed == {o for o in on}
        assert isinstance(session, TrueFacts)
        true_on = {a.args[0] for a in session.true_facts() if a.predicate == location}
        assert {s.name for s in view.truth} == true_on


# ----------------------------------------------------------------------- throttling


def _counts(path: Path) -> dict[str, int]:
    counts: dict[str, int] = {}
    for _schema, channel, _message in _messages(path):
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return counts


@pytest.mark.parametrize("period", [0.0, 1e9])
def test_the_scene_is_throttled_and_nothing_else_is_dropped(period: float, tmp_path: Path) -> None:
    """A clock that never moves: with a period the scene goes out only at each round's start
    and end (and once at the start); without one, at every tick too. Tree, plan, anomaly and
    LLM messages are the same either way: one per tick that changed the tree, one per anomaly,
    prompt and answer."""
    from llmpas.system import run
    from llmpas.system.catalog import llm_for, load_world

    class Sink(FoxgloveSink):  # the sink, with every tick it was told of
        ticks: list[tuple[int, Any]]

        def ticked(self, index: int, tick: Any) -> None:
            self.ticks.append((index, (tick.nodes, tick.steps, tick.status)))
            super().ticked(index, tick)

    path = tmp_path / "run.mcap"
    with Sink(path, scene_period=period, clock=lambda: 0.0) as sink:
        sink.ticks = []
        result = run(load_world("household"), HOUSEHOLD, llm_for("oracle", None, "household"),
                     observer=sink)  # fmt: skip
    counts = _counts(path)
    rounds = len(result.rounds)
    ticks = sum(r.episode.ticks for r in result.rounds if r.episode is not None)
    assert len(sink.ticks) == ticks
    changed = [t for k, t in enumerate(sink.ticks) if k == 0 or t != sink.ticks[k - 1]]
    forced = 1 + 2 * rounds
    assert counts["/llmpas/scene"] == (forced if period else forced + ticks)
    assert counts["/llmpas/tree"] == len(changed)  # a tick that changed nothing is folded
    assert counts["/llmpas/anomaly"] == sum(
        1 for r in result.rounds if r.episode and r.episode.anomaly
    )
    exchanges = sum(len(r.proposal.exchanges) for r in result.rounds if r.proposal)
    verdicts = sum(1 for r in result.rounds if r.proposal)
    assert counts["/llmpas/llm"] == 2 * exchanges + verdicts
    assert counts["/llmpas/plan"] >= rounds


# ----------------------------------------------------------------------- the layout and the picture


def test_the_shipped_layout_is_the_one_built_and_shows_the_channels(main_job: Path) -> None:
    from llmpas.reporting.live import LAYOUT, layout

    shipped = json.loads((ROOT / "docs" / "foxglove-layout.json").read_text())
    assert shipped == json.loads(layout())  # docs/ is regenerated when the layout changes
    assert json.loads((main_job / LAYOUT).read_text()) == shipped  # beside every run.mcap
    text = json.dumps(shipped)
    for topic in TOPICS:
        if topic != "/llmpas/tf":  # the 3-D panel reads the frames by itself
            assert f'"{topic}' in text, topic


def test_the_main_jobs_run_mcap_is_drawn(main_job: Path, tmp_path: Path) -> None:
    pytest.importorskip("mcap_protobuf")
    from llmpas.reporting.mcap_picture import at, draw, read

    got = read(main_job / "run.mcap")
    assert got.anomalies and got.verdicts and got.scenes and got.truths and got.frames
    names = {e.id for e in got.scenes[0][1].entities}
    assert any(n.startswith("believed/place/") for n in names)
    # the PyBullet world's own geometry: at the anomaly the cube is believed where it is not
    anomaly_t = got.anomalies[0][0]

    def has(update: Any, layer: str) -> bool:
        return any(e.id == f"{layer}/object/cube" for e in update.entities)

    def cube(update: Any, layer: str) -> tuple[float, float]:
        (e,) = [e for e in update.entities if e.id == f"{layer}/object/cube"]
        return e.cubes[0].pose.position.x, e.cubes[0].pose.position.y

    # which scenes fall between the look that lost the cube and the anomaly's report depends on
    # the scene's throttle (a clock): read the belief at its last scene showing the cube (the
    # round's plan forces one) and the truth at the scene forced right after the report
    shown = [u for s, u in got.scenes if s <= anomaly_t and has(u, "believed")]
    after = [u for s, u in got.truths if s >= anomaly_t]
    believed, true = cube(shown[-1], "believed"), cube(after[0], "truth")
    assert math.dist(believed, true) > 0.5
    frames = {f.child_frame_id for f in at(got.frames, anomaly_t).transforms}
    assert {"base_link", "gripper", "panda_link1", "panda_hand"} <= frames
    png = draw(main_job / "run.mcap", tmp_path / "live.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_bench_runs_the_main_job_with_and_without_the_sink(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    out = tmp_path / "live.json"
    assert main(["bench", "live", "--repeats", "1", "--json", str(out)]) == 0
    got = json.loads(out.read_text())
    assert got["same"] and got["complete"]
    assert got["ratio"] > 0 and got["sink_seconds"] > 0
    (with_sink,) = got["runs"]["with"]
    assert with_sink["topics"]["/llmpas/anomaly"] == 1
    assert with_sink["mcap_prompts"] == with_sink["prompts"] > 0


def test_ticks_that_change_nothing_are_folded_into_the_next(tmp_path: Path) -> None:
    from llmpas.execution.executor import Tick

    running = (("plan", "RUNNING", 0), ("move", "RUNNING", 1))
    done = (("plan", "SUCCESS", 0), ("move", "SUCCESS", 1))
    ticks = [Tick(1, running, (0,), "RUNNING"), Tick(2, running, (0,), "RUNNING"),
             Tick(3, running, (0,), "RUNNING"), Tick(4, done, (0,), "SUCCESS")]  # fmt: skip
    path = tmp_path / "run.mcap"
    with FoxgloveSink(path) as sink:
        for t in ticks:
            sink.ticked(0, t)
    sent = [json.loads(m.data) for _, c, m in _messages(path) if c.topic == "/llmpas/tree"]
    assert [(m["tick"], m["folded"]) for m in sent] == [(1, 0), (4, 2)]


def test_a_users_world_written_only_against_the_protocol_gets_the_channels(tmp_path: Path) -> None:
    """The library world of tests/worlds/test_protocol.py (no geometry, no truth): its shelves
    and the believed atlas on the scene channel, the tree, the plan, the anomaly and the LLM; no
    truth layer, no frames."""
    import py_trees

    from llmpas.system import LoopSettings, run

    from ..worlds.test_protocol import Library, Scripted

    py_trees.blackboard.Blackboard.clear()
    path = tmp_path / "run.mcap"
    llm = Scripted("(and (inspected shelf3))")
    with FoxgloveSink(path) as sink:
        result = run(Library(), "atlas-on-shelf3", llm, LoopSettings(), observer=sink)
    py_trees.blackboard.Blackboard.clear()
    assert result.success
    counts = _counts(path)
    for topic in WATCHED:
        assert counts.get(topic, 0) >= 1, topic
    assert "/llmpas/scene/truth" not in counts and "/llmpas/tf" not in counts
    pytest.importorskip("mcap_protobuf")
    from llmpas.reporting.mcap_picture import read

    first = read(path).scenes[0][1]
    ids = {e.id for e in first.entities}
    assert ids == {f"believed/place/shelf{i}" for i in (1, 2, 3)} | {"believed/object/atlas"}


def test_an_interrupted_run_leaves_a_complete_run_mcap(tmp_path: Path) -> None:
    """Ctrl-C while the LLM is asked: the sink closes run.mcap (its summary written) and its
    last loop message says the run was interrupted."""
    from llmpas.reasoning.llm import Request, Response
    from llmpas.system import run
    from llmpas.system.catalog import load_world

    class Interrupted:
        name = "interrupted"

        def complete(self, request: Request) -> Response:
            raise KeyboardInterrupt

    path = tmp_path / "run.mcap"
    with pytest.raises(KeyboardInterrupt), FoxgloveSink(path) as sink:
        run(load_world("household"), HOUSEHOLD, Interrupted(), observer=sink)
    with path.open("rb") as f:
        summary = mcap_reader.make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    loop = [json.loads(m.data) for _, c, m in _messages(path) if c.topic == "/llmpas/loop"]
    assert loop[-1]["status"] == "interrupted"
    assert _counts(path)["/llmpas/anomaly"] == 1


def test_exchanges_not_told_as_they_happened_are_written_once_with_the_verdict(
    tmp_path: Path,
) -> None:
    """The prompts and answers go out live (``prompted``, ``replied``); any exchange of the
    consultation the sink was not told of (a request that never reached the LLM's wrapper)
    goes out with the verdict, so the LLM channel always holds each exchange once."""
    from llmpas.system import run
    from llmpas.system.catalog import llm_for, load_world

    class Deaf(FoxgloveSink):  # told of no request while it happened
        def prompted(self, index: int, request: Any) -> None:
            if self.publishing:
                super().prompted(index, request)

        def replied(self, index: int, request: Any, response: Any) -> None:
            pass

        def answered(self, index: int, proposal: Any) -> None:
            self.publishing = True
            super().answered(index, proposal)
            self.publishing = False

    path = tmp_path / "run.mcap"
    with Deaf(path) as sink:
        sink.publishing = False
        result = run(load_world("household"), HOUSEHOLD, llm_for("oracle", None, "household"),
                     observer=sink)  # fmt: skip
    llm = [json.loads(m.data) for _, c, m in _messages(path) if c.topic == "/llmpas/llm"]
    exchanges = [e for r in result.rounds if r.proposal for e in r.proposal.exchanges]
    assert [m["text"] for m in llm if m["kind"] == "answer"] == [e.response.text for e in exchanges]
    assert len([m for m in llm if m["kind"] == "prompt"]) == len(exchanges)


def test_the_replan_only_run_has_its_run_mcap_too(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert main(["run", HOUSEHOLD, "--llm", "oracle", "--out", str(out), "--with-replan"]) == 0
    for folder in (out, out / "replan-only"):
        loop = [json.loads(m.data) for _, c, m in _messages(folder / "run.mcap")
                if c.topic == "/llmpas/loop"]  # fmt: skip
        assert loop[-1]["status"] == json.loads((folder / "loop.json").read_text())["status"]


def test_an_execute_folder_has_its_run_mcap(tmp_path: Path) -> None:
    assert main(["execute", "nominal", "--out", str(tmp_path)]) == 0
    counts = _counts(tmp_path / "run.mcap")
    assert counts["/llmpas/plan"] >= 1 and counts["/llmpas/tree"] >= 1
    assert "/llmpas/llm" not in counts  # no LLM in a single execution
