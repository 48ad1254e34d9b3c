"""Backends over real HTTP (a local stdlib server), record/replay cassettes, llama.cpp."""

from __future__ import annotations

import json
import logging
import os
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from llmpas.reasoning.backends import LlamaCppBackend, OpenAIBackend, ReplayBackend
from llmpas.reasoning.llm import LLM, Fault, LLMError, LLMServerError, Message, Request, Response

from ..llm_server import ERROR_500, FakeServer, Reply, completion_body, echo_authorization, serve
from ..tiny_model import needs_tiny_model, sample, tiny_backend

SECRET = "sk-test-SECRET-do-not-log-1234567890"


@pytest.fixture
def server() -> Iterator[FakeServer]:
    with serve() as fake:
        yield fake


def request(**kw: Any) -> Request:
    messages = (Message("system", "You write goals."), Message("user", "cube fell"))
    return Request(messages=messages, **kw)


def backend(url: str, **kw: Any) -> OpenAIBackend:
    kw.setdefault("backoff", 0.01)
    return OpenAIBackend("fake-model", base_url=url, api_key=SECRET, **kw)


# --- OpenAIBackend --------------------------------------------------------------------------


def test_openai_backend_is_an_llm(server: FakeServer) -> None:
    assert isinstance(backend(server.url), LLM)


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


def test_openai_grammar_passed_through_extra_body(server: FakeServer) -> None:
    grammar = 'root ::= "(and (on cube bowl))"'
    backend(server.url).complete(request(grammar=grammar))
    [body] = server.received
    assert body["grammar"] == grammar
    assert "response_format" not in body
    assert "seed" not in body  # seed None is omitted, not sent as null


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


def test_openai_500_is_retried_then_fails(server: FakeServer) -> None:
    server.replies[:] = [Reply(500, ERROR_500)]
    with pytest.raises(LLMError, match="500") as err:
        backend(server.url, max_retries=2).complete(request())
    assert len(server.received) == 3  # max_retries + 1 attempts
    assert "\n" not in str(err.value)


def test_openai_recovers_after_transient_500(server: FakeServer) -> None:
    server.replies[:] = [Reply(500, ERROR_500), Reply(200, completion_body("second"))]
    assert backend(server.url, max_retries=2).complete(request()).text == "second"
    assert len(server.received) == 2


def test_openai_backoff_is_exponential(server: FakeServer) -> None:
    server.replies[:] = [Reply(503, ERROR_500)]
    delays: list[float] = []
    llm = OpenAIBackend("m", base_url=server.url, max_retries=3, backoff=0.5, sleep=delays.append)
    with pytest.raises(LLMError, match="503"):
        llm.complete(request())
    assert delays == [0.5, 1.0, 2.0]


def test_openai_client_error_is_not_retried(server: FakeServer) -> None:
    server.replies[:] = [Reply(400, b'{"error": {"message": "bad grammar"}}')]
    with pytest.raises(LLMError, match="400"):
        backend(server.url, max_retries=2).complete(request())
    assert len(server.received) == 1


def test_openai_timeout(server: FakeServer) -> None:
    server.replies[:] = [Reply(200, completion_body("late"), delay=30.0)]
    with pytest.raises(LLMServerError, match=r"timed out after 0\.3 s") as err:
        backend(server.url, timeout=0.3, max_retries=1).complete(request())
    assert err.value.fault is Fault.TIMEOUT
    assert len(server.received) == 2  # retried once, then given up (the server never answered)


def test_openai_connection_refused() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    url = f"http://127.0.0.1:{port}/v1"
    with pytest.raises(LLMError, match=f"fake-model at 127.0.0.1:{port}: connection failed"):
        backend(url, max_retries=1).complete(request())


def test_openai_needs_a_key_only_without_base_url(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    monkeypatch.delenv("OPENAI_BASE_URL", raising=False)
    with pytest.raises(LLMError, match="OPENAI_API_KEY"):
        OpenAIBackend("gpt-4o-mini")
    OpenAIBackend("local", base_url="http://127.0.0.1:1/v1")  # dummy key for local servers


# --- OpenAIBackend against a hostile server -------------------------------------------------

HOSTILE_200 = [
    (b'{"choices": "nope"}', "answer.choices is a str"),
    (b'{"choices": []}', "answer.choices is empty"),
    (b'{"choices": [{"message": {"content": 7}}]}', "content is a int"),
    (b'{"choices": [null]}', "choices[0] is not an object"),
    (b"[1, 2]", "answer is not an object"),
    (b"<html>Bad gateway</html>", "answer is not JSON"),
    (b"", "answer is not JSON"),
    (b"\xff\xfe{}", "answer is not UTF-8"),
    (b'{"choices": [{"message": {"content": "\xed\xa0\x80"}}]}', "answer is not UTF-8"),
    (b"[" * 100_000, "answer is not JSON"),
    (b"1" * 5000, "answer is not JSON"),
]


@pytest.mark.parametrize(("body", "reason"), HOSTILE_200)
def test_openai_malformed_answers_are_one_line_errors_naming_the_server(
    body: bytes, reason: str
) -> None:
    with serve(Reply(200, body)) as srv, pytest.raises(LLMServerError) as err:
        backend(srv.url).complete(request())
    port = srv.url.split(":")[-1].split("/")[0]
    assert err.value.fault is Fault.MALFORMED
    assert str(err.value).startswith(f"openai:fake-model at 127.0.0.1:{port}: ")
    assert reason in str(err.value)
    assert "\n" not in str(err.value)
    assert len(srv.received) == 1  # a malformed answer is not retried


def test_openai_lone_surrogates_are_data_not_a_crash() -> None:
    body = b'{"choices": [{"message": {"content": "(and \\ud800 (on cube bowl))"}}]}'
    with serve(Reply(200, body)) as srv:
        resp = backend(srv.url).complete(request())
    assert resp.text == "(and \ud800 (on cube bowl))"


def test_openai_answer_size_is_bounded() -> None:
    big = completion_body("x" * 300_000)
    with serve(Reply(200, big)) as srv:
        with pytest.raises(LLMServerError, match="larger than 100000 bytes") as err:
            backend(srv.url, max_bytes=100_000).complete(request())
        assert err.value.fault is Fault.TOO_LARGE
        assert len(backend(srv.url).complete(request()).text) == 300_000  # under the default


def test_openai_slow_trickle_is_cut_by_the_attempt_deadline() -> None:
    # each byte comes well within the socket timeout; only the attempt deadline can stop it
    slow = Reply(200, completion_body("late"), trickle=0.05)
    with serve(slow) as srv, pytest.raises(LLMServerError, match=r"timed out after 0\.4 s") as err:
        backend(srv.url, timeout=0.4, max_retries=0).complete(request())
    assert err.value.fault is Fault.TIMEOUT


def test_openai_401_echoing_the_key_is_redacted(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG)
    with serve(Reply(401, echo_authorization)) as srv:
        with pytest.raises(LLMServerError, match="HTTP 401") as err:
            backend(srv.url, max_retries=2).complete(request())
        assert srv.headers[0]["authorization"] == f"Bearer {SECRET}"  # it was sent
        assert len(srv.received) == 1  # a 401 is not retried
    assert err.value.status == 401
    assert "invalid credentials" in str(err.value)
    assert SECRET not in str(err.value) and SECRET[8:20] not in str(err.value)
    assert "[REDACTED]" in str(err.value)
    assert SECRET not in caplog.text


def test_openai_answer_echoing_the_key_is_redacted() -> None:
    text = f"my key is {SECRET}, and as JSON {json.dumps(SECRET)}"
    with serve(Reply(200, completion_body(text))) as srv:
        resp = backend(srv.url).complete(request())
    assert SECRET not in resp.text and "[REDACTED]" in resp.text


def test_openai_bad_urls_are_value_errors() -> None:
    for url in ("ftp://host/v1", "http:///v1", "http://host:99999/v1"):
        with pytest.raises(ValueError, match="LLM server URL"):
            OpenAIBackend("m", base_url=url)


def test_openai_url_credentials_never_reach_the_name() -> None:
    llm = OpenAIBackend("m", base_url="http://user:hunter2pass@127.0.0.1:9/v1?key=abcdefgh")
    assert "hunter2pass" not in llm.server + llm.base_url + repr(llm)
    assert "abcdefgh" not in llm.server + llm.base_url + repr(llm)


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


def test_recorded_latency_is_counted_once(tmp_path: Path) -> None:
    """--record (auto): a repeated request served from its cassette took no model time; a
    replay counts each cassette's recorded latency the first time only (a --record run of
    39.5 s reported 115.7 s of LLM latency)."""
    inner = ScriptedLLM("first", "second")
    llm = ReplayBackend(tmp_path, inner, mode="auto")
    latencies = [llm.complete(request()).latency for _ in range(3)]
    assert latencies == [0.25, 0.0, 0.0] and inner.calls == 1
    again = ReplayBackend(tmp_path, ScriptedLLM("third"), mode="auto").complete(request())
    assert again.latency == 0.0 and again.meta["recorded_latency"] == 0.25  # an earlier run's
    replay = ReplayBackend(tmp_path)
    assert [replay.complete(request()).latency for _ in range(3)] == [0.25, 0.0, 0.0]


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


def test_lone_surrogates_are_recorded_and_replayed_intact(tmp_path: Path) -> None:
    # a repair prompt quotes the previous answer: the request holds surrogates too
    req = Request((Message("user", "you said \ud800; try again"),), tag="repair-1")
    answer = "(and \udfff (on cube bowl)) \x1b[2J"
    ReplayBackend(tmp_path, ScriptedLLM(answer), mode="record").complete(req)
    [cassette] = tmp_path.iterdir()
    cassette.read_text(encoding="utf-8")  # valid UTF-8 on disk
    assert ReplayBackend(tmp_path).complete(req).text == answer


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


@needs_tiny_model
def test_llamacpp_smollm2_follows_grammar() -> None:
    llm = tiny_backend(n_ctx=512)
    req = Request(
        messages=(Message("user", "Put the cube in the bowl. Answer with a goal."),),
        max_tokens=32,
        grammar='root ::= "(and (on cube bowl))"',
    )
    resp = llm.complete(req)
    assert resp.text == "(and (on cube bowl))"  # the only string the grammar admits
    assert resp.completion_tokens > 0
    assert resp.prompt_tokens > 0


@needs_tiny_model
@pytest.mark.parametrize(
    "grammar",
    ['root ::= "a" undefined-rule', 'root ::= "unterminated', 'root ::= ( "a"', "no rules at all"],
)
def test_llamacpp_an_invalid_grammar_is_an_llm_error(grammar: str) -> None:
    """llama.cpp really parses the grammar: a broken one is refused, not ignored."""
    with pytest.raises(LLMError, match="grammar"):
        sample(tiny_backend(n_ctx=512), grammar, "Say something.", max_tokens=8)


def test_the_http_deadline_comes_from_llmpas_llm_timeout(monkeypatch: pytest.MonkeyPatch) -> None:
    from llmpas.reasoning.backends.backend_registry import make_backend

    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")
    monkeypatch.delenv("LLMPAS_LLM_TIMEOUT", raising=False)
    assert make_backend("openai:m@http://127.0.0.1:9/v1").timeout == 30.0
    monkeypatch.setenv("LLMPAS_LLM_TIMEOUT", "1200")
    assert make_backend("openai:m@http://127.0.0.1:9/v1").timeout == 1200.0
    for bad in ("soon", "0", "-5", "inf", "nan"):
        monkeypatch.setenv("LLMPAS_LLM_TIMEOUT", bad)
        with pytest.raises(ValueError, match=r"LLMPAS_LLM_TIMEOUT=.*positive number of seconds"):
            make_backend("openai:m@http://127.0.0.1:9/v1")
