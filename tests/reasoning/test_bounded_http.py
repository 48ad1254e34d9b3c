"""The bounded transport against a raw-socket server on 127.0.0.1 that never stops talking."""

from __future__ import annotations

import gzip
import queue
import re
import socket
import ssl
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field

import httpx2 as httpx
import pytest
import trustme

from llmpas.reasoning.backends import OpenAIBackend
from llmpas.reasoning.backends.bounded_http import BodyTooLarge, BoundedTransport, DeadlinePassed
from llmpas.reasoning.llm import Fault, LLMError, LLMServerError, Message, Request

GUARD = 60.0  # seconds: the server hangs up by then (a hang guard, never a speed assertion)
Talk = Callable[[socket.socket, threading.Event], None]


@dataclass
class Server:
    url: str
    requests: list[bytes] = field(default_factory=list)
    ends: queue.Queue[str] = field(default_factory=queue.Queue)  # how each connection ended

    def next_end(self) -> str:
        """``"finished"`` (said everything), ``"hung up on"`` (by the client), or a failure."""
        return self.ends.get(timeout=GUARD + 10)


def read_request(conn: socket.socket) -> bytes:
    """The request's head and its body (``Content-Length`` bytes), however it is split."""
    data = b""
    while b"\r\n\r\n" not in data:
        data += conn.recv(1 << 16) or b"\r\n\r\n"
    head, _, body = data.partition(b"\r\n\r\n")
    length = re.search(rb"(?i)content-length: *(\d+)", head)
    while length and len(body) < int(length[1]) and (more := conn.recv(1 << 16)):
        body += more
    return head + b"\r\n\r\n" + body


@contextmanager
def raw_server(talk: Talk, tls: ssl.SSLContext | None = None) -> Iterator[Server]:
    """Accepts connections on 127.0.0.1 (over TLS with ``tls``) and lets ``talk`` write whatever
    it likes to each."""
    stop = threading.Event()
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.05)
    scheme = "https" if tls else "http"
    server = Server(f"{scheme}://127.0.0.1:{listener.getsockname()[1]}/v1")

    def serve_one(raw: socket.socket) -> None:
        raw.settimeout(GUARD)
        try:
            with tls.wrap_socket(raw, server_side=True) if tls else raw as conn:
                server.requests.append(read_request(conn))
                talk(conn, stop)
            server.ends.put("finished")
        except OSError:  # ssl.SSLError too
            server.ends.put("hung up on")
        except AssertionError as err:
            server.ends.put(f"failed: {err}")
        finally:
            raw.close()

    def accept() -> None:
        while not stop.is_set():
            with suppress(TimeoutError):
                conn, _ = listener.accept()
                threading.Thread(target=serve_one, args=(conn,), daemon=True).start()

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield server
    finally:
        stop.set()
        thread.join(timeout=5)
        listener.close()


def endless_body(status: int) -> Talk:
    def talk(conn: socket.socket, stop: threading.Event) -> None:
        conn.sendall(f"HTTP/1.1 {status} X\r\nContent-Type: application/json\r\n\r\n".encode())
        chunk = b'{"choices": "' + b"x" * 65_536
        for _ in range(int(GUARD * 100)):  # about 40 GB if nothing stops the client
            if stop.is_set():
                return
            conn.sendall(chunk)

    return talk


def trickle(head: bytes, *, then: bytes) -> Talk:
    """Sends ``head``, then ``then`` byte after byte every 20 ms, for up to GUARD seconds."""

    def talk(conn: socket.socket, stop: threading.Event) -> None:
        conn.sendall(head)
        for i in range(int(GUARD / 0.02)):
            if stop.wait(0.02):
                return
            conn.sendall(then[i % len(then) : i % len(then) + 1])

    return talk


def client(
    seconds: float, max_bytes: int = 1 << 20, verify: ssl.SSLContext | bool = True
) -> httpx.Client:
    # each read may wait as long as GUARD: only the transport's deadline can end a trickle
    transport = BoundedTransport(seconds, max_bytes, verify=verify)
    return httpx.Client(transport=transport, timeout=httpx.Timeout(GUARD))


@pytest.fixture(scope="module")
def tls() -> tuple[ssl.SSLContext, ssl.SSLContext]:
    """A certificate for 127.0.0.1 from a throwaway CA: (server context, client context)."""
    ca = trustme.CA()
    server, client = (
        ssl.create_default_context(ssl.Purpose.CLIENT_AUTH),
        ssl.create_default_context(),
    )
    ca.issue_cert("127.0.0.1").configure_cert(server)
    ca.configure_trust(client)
    return server, client


def test_an_endless_body_is_cut_at_the_size_cap() -> None:
    with raw_server(endless_body(200)) as srv:
        with pytest.raises(BodyTooLarge, match="100000 bytes"):
            client(GUARD, max_bytes=100_000).post(srv.url, content=b"{}")
        assert srv.next_end() == "hung up on"


def test_a_trickled_body_is_cut_at_the_deadline() -> None:
    head = b"HTTP/1.1 200 OK\r\nContent-Length: 100000\r\n\r\n"
    with raw_server(trickle(head, then=b"x")) as srv:
        with pytest.raises(DeadlinePassed, match=r"0\.5 s"):
            client(0.5).post(srv.url, content=b"{}")
        assert srv.next_end() == "hung up on"  # not waited out to the end of the trickle


def test_trickled_headers_are_cut_at_the_deadline() -> None:
    # no body yet: the per-chunk check cannot help, only the watchdog shutting the socket
    with raw_server(trickle(b"HTTP/1.1 200 OK\r\n", then=b"X-Slow: a\r\n")) as srv:
        with pytest.raises(DeadlinePassed, match=r"0\.5 s"):
            client(0.5).post(srv.url, content=b"{}")
        assert srv.next_end() == "hung up on"


def test_trickled_headers_over_tls_are_cut_at_the_deadline(
    tls: tuple[ssl.SSLContext, ssl.SSLContext],
) -> None:
    talk = trickle(b"HTTP/1.1 200 OK\r\n", then=b"X-Slow: a\r\n")
    with raw_server(talk, tls=tls[0]) as srv:
        with pytest.raises(DeadlinePassed, match=r"0\.5 s"):
            client(0.5, verify=tls[1]).post(srv.url, content=b"{}")
        assert srv.next_end() == "hung up on"


def test_an_answer_over_tls_passes_intact(tls: tuple[ssl.SSLContext, ssl.SSLContext]) -> None:
    body = b'{"ok": true}'

    def talk(conn: socket.socket, stop: threading.Event) -> None:
        conn.sendall(f"HTTP/1.1 200 OK\r\nContent-Length: {len(body)}\r\n\r\n".encode() + body)

    with raw_server(talk, tls=tls[0]) as srv:
        assert client(GUARD, verify=tls[1]).post(srv.url, content=b"{}").content == body
        assert srv.next_end() == "finished"


def test_an_answer_within_the_limits_passes_intact() -> None:
    body = b'{"ok": true}' + b" " * 5000

    def talk(conn: socket.socket, stop: threading.Event) -> None:
        head = f"HTTP/1.1 200 OK\r\nContent-Length: {len(body)}\r\n\r\n".encode()
        conn.sendall(head + body)
        conn.settimeout(GUARD)
        assert conn.recv(1) == b"", "a second request on the same connection"

    with raw_server(talk) as srv:
        http = client(GUARD, max_bytes=len(body))
        assert [http.post(srv.url, content=b"{}").content for _ in range(3)] == [body] * 3
        # a fresh connection for each request: the watchdog always has its socket
        assert [srv.next_end() for _ in range(3)] == ["finished"] * 3


def test_a_compressed_answer_is_never_inflated_past_the_cap() -> None:
    bomb = gzip.compress(b" " * 20_000_000)  # about 20 kB that inflate to 20 MB

    def talk(conn: socket.socket, stop: threading.Event) -> None:
        head = f"HTTP/1.1 200 OK\r\nContent-Encoding: gzip\r\nContent-Length: {len(bomb)}\r\n\r\n"
        conn.sendall(head.encode() + bomb)

    with raw_server(talk) as srv:
        response = client(GUARD, max_bytes=100_000).post(srv.url, content=b"{}")
    assert response.content == bomb  # as it came, within the cap
    assert srv.requests[0].lower().count(b"accept-encoding: identity") == 1


def test_limits_are_validated() -> None:
    with pytest.raises(ValueError, match="seconds"):
        BoundedTransport(0.0, 10)
    with pytest.raises(ValueError, match="max_bytes"):
        BoundedTransport(1.0, 0)


@pytest.mark.parametrize("status", [200, 500])
def test_the_backend_reports_an_endless_answer_or_error_body_as_too_large(status: int) -> None:
    request = Request(messages=(Message("user", "cube fell"),))
    with raw_server(endless_body(status)) as srv, pytest.raises(LLMServerError) as err:
        OpenAIBackend("m", base_url=srv.url, max_bytes=100_000, max_retries=0).complete(request)
    assert err.value.fault is Fault.TOO_LARGE
    assert "larger than 100000 bytes" in str(err.value)
    assert f"openai:m at {srv.url.split('/')[2]}: " in str(err.value)


def test_the_backend_without_the_openai_package_is_an_llm_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "openai", None)  # makes `import openai` fail
    with pytest.raises(LLMError, match=r"pip install 'llmpas\[llm\]'"):
        OpenAIBackend("m", base_url="http://127.0.0.1:9/v1")
