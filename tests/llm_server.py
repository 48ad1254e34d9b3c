"""A scriptable OpenAI-compatible server on 127.0.0.1 for tests, able to misbehave.

It answers ``POST .../chat/completions`` with the next scripted :class:`Reply` (the last one
repeats; any other path: 404): any status and body (a body may be a function of the request's
headers, e.g. a 401 echoing the ``Authorization`` header), sent after a delay or trickled byte by
byte. Everything
is bounded: waits end when the server stops, request bodies are capped, threads are daemons.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

MAX_REQUEST = 4 << 20


def completion_body(text: str, prompt_tokens: int = 12, completion_tokens: int = 5) -> bytes:
    """A ``/v1/chat/completions`` answer, as an OpenAI-compatible server sends it."""
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

Body = bytes | Callable[[Mapping[str, str]], bytes]  # a function of the request's headers


def echo_authorization(headers: Mapping[str, str]) -> bytes:
    """A 401 body that repeats the credentials it was sent (a real, if careless, pattern)."""
    auth = headers.get("authorization", "")
    message = f"invalid credentials: {auth!s} (header Authorization: {auth})"
    return json.dumps({"error": {"message": message, "received": auth}}).encode()


@dataclass(frozen=True)
class Reply:
    status: int
    body: Body
    delay: float = 0.0  # seconds before the status line
    trickle: float = 0.0  # seconds between body bytes (a slow answer)


@dataclass
class FakeServer:
    """What the server answers (the last reply repeats) and what it received."""

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
        if not self.path.endswith("/chat/completions"):  # as OpenAI: no other endpoint here
            self.send_response(404)
            self.send_header("Content-Length", "0")
            self.end_headers()
            return
        length = min(int(self.headers.get("Content-Length", 0)), MAX_REQUEST)
        body = json.loads(self.rfile.read(length) or b"{}")
        headers = {k.lower(): v for k, v in self.headers.items()}
        self.fake.received.append({"path": self.path, **body})
        self.fake.headers.append(headers)
        reply = self.fake.next_reply()
        data = reply.body(headers) if callable(reply.body) else reply.body
        if reply.delay and self.fake.stop.wait(reply.delay):
            return
        try:
            self.send_response(reply.status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            if not reply.trickle:
                self.wfile.write(data)
                return
            for i in range(len(data)):
                if self.fake.stop.wait(reply.trickle):
                    return
                self.wfile.write(data[i : i + 1])
                self.wfile.flush()
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up (timeouts)

    def log_message(self, format: str, *args: Any) -> None:
        pass


@contextmanager
def serve(*replies: Reply) -> Iterator[FakeServer]:
    """A server on 127.0.0.1 (a free port) answering ``replies``; ``url`` ends in ``/v1``."""
    default = Reply(200, completion_body("(and (on cube bowl))"))
    fake = FakeServer(url="", replies=list(replies) or [default])
    with _serving(Handler, fake):
        yield fake


@contextmanager
def _serving(handler: type[Handler], fake: FakeServer) -> Iterator[None]:
    """``handler`` bound to ``fake``, served on 127.0.0.1 (a free port) until the block ends."""
    bound = type("Bound" + handler.__name__, (handler,), {"fake": fake})
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), bound)
    httpd.daemon_threads = True
    fake.url = f"http://127.0.0.1:{httpd.server_address[1]}/v1"
    thread = threading.Thread(target=httpd.serve_forever, args=(0.05,), daemon=True)
    thread.start()
    try:
        yield
    finally:
        fake.stop.set()
        httpd.shutdown()
        httpd.server_close()
        thread.join(timeout=5)


Answer = Callable[[dict[str, Any]], bytes]  # a chat completion's body, from the request's


@contextmanager
def serve_answers(answer: Answer) -> Iterator[FakeServer]:
    """A server on 127.0.0.1 whose every chat completion is ``answer(request body)`` (status
    200; any other path: 404): a scripted model that reads what it is asked."""

    def body(headers: Mapping[str, str]) -> bytes:  # pragma: no cover - replaced per request
        raise AssertionError("answers come from the request")

    class Answering(Handler):
        def do_POST(self) -> None:
            if not self.path.endswith("/chat/completions"):
                self.send_response(404)
                self.send_header("Content-Length", "0")
                self.end_headers()
                return
            length = min(int(self.headers.get("Content-Length", 0)), MAX_REQUEST)
            request = json.loads(self.rfile.read(length) or b"{}")
            self.fake.received.append({"path": self.path, **request})
            data = answer(request)
            try:
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)
            except (BrokenPipeError, ConnectionResetError):
                pass

    fake = FakeServer(url="", replies=[Reply(200, body)])
    with _serving(Answering, fake):
        yield fake


def scored_body(text: str, logprob: float) -> bytes:
    """A chat completion that answers ``text``, one token per character, each with
    ``logprob``: what a scoring request's forced answer looks like."""
    tokens = [{"token": c, "logprob": logprob, "top_logprobs": []} for c in text]
    body = json.loads(completion_body(text))
    body["choices"][0]["logprobs"] = {"content": tokens}
    return json.dumps(body).encode()
