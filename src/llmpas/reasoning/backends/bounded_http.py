"""An ``httpx`` transport that bounds every request it sends: one deadline, one size cap.

:class:`BoundedTransport` wraps ``httpx.HTTPTransport`` (``httpx2``, the HTTP library of the
``openai`` SDK). Each request gets a fresh connection and a deadline covering connecting,
sending, the headers and the body: a watchdog shuts the socket down when it passes (which
unblocks a read waiting on a server that trickles its answer byte by byte), and the body's
stream checks the deadline and the size cap on every chunk. Past the deadline every failure is
a :class:`DeadlinePassed` (an ``httpx.ReadTimeout``); a body over the cap, error bodies
included, is a :class:`BodyTooLarge` (an ``httpx.ReadError``). The answer is asked for
uncompressed (``Accept-Encoding: identity``) and a ``Content-Encoding`` sent anyway is dropped,
so the body is kept as it came: the cap bounds what is held, never inflated by a gzip bomb.
"""

from __future__ import annotations

import contextlib
import socket
import ssl
import threading
from collections.abc import Iterator
from typing import Any, cast

import httpx2 as httpx


class DeadlinePassed(httpx.ReadTimeout):
    """The request's deadline passed (connecting, sending, headers or body)."""


class BodyTooLarge(httpx.ReadError):
    """The answer's body is larger than the cap."""


class BoundedTransport(httpx.BaseTransport):
    """Sends each request within ``seconds``, reading at most ``max_bytes`` of its answer;
    ``verify``: TLS certificates checked against the system's roots, or this context's."""

    def __init__(
        self, seconds: float, max_bytes: int, *, verify: ssl.SSLContext | bool = True
    ) -> None:
        if not seconds > 0:
            raise ValueError(f"seconds must be > 0, got {seconds}")
        if max_bytes < 1:
            raise ValueError(f"max_bytes must be >= 1, got {max_bytes}")
        self.seconds = seconds
        self.max_bytes = max_bytes
        # no connection kept alive: every request connects, so the watchdog sees its socket
        limits = httpx.Limits(max_keepalive_connections=0)
        self._inner = httpx.HTTPTransport(verify=verify, limits=limits, retries=0)

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        watchdog = _Watchdog(self.seconds)
        request.extensions["trace"] = watchdog.trace
        request.headers["Accept-Encoding"] = "identity"
        try:
            response = self._inner.handle_request(request)
        except BaseException as err:
            watchdog.cancel()
            if isinstance(err, httpx.TransportError) and watchdog.expired.is_set():
                raise watchdog.passed(request) from err
            raise
        inner = cast(httpx.SyncByteStream, response.stream)
        stream = _BoundedStream(inner, request, watchdog, self.max_bytes)
        # compressed anyway: kept as it came (not JSON), never inflated past the cap by httpx
        headers = [(k, v) for k, v in response.headers.raw if k.lower() != b"content-encoding"]
        return httpx.Response(
            status_code=response.status_code,
            headers=headers,
            stream=stream,
            extensions=response.extensions,
        )

    def close(self) -> None:
        self._inner.close()


class _BoundedStream(httpx.SyncByteStream):
    def __init__(
        self, inner: httpx.SyncByteStream, request: httpx.Request, watchdog: _Watchdog, limit: int
    ) -> None:
        self._inner = inner
        self._request = request
        self._watchdog = watchdog
        self._limit = limit

    def __iter__(self) -> Iterator[bytes]:
        size = 0
        try:
            for chunk in self._inner:
                size += len(chunk)
                self._check(size)
                yield chunk
        except httpx.TransportError as err:  # the watchdog may have shut the socket mid-body
            if (
                isinstance(err, DeadlinePassed | BodyTooLarge)
                or not self._watchdog.expired.is_set()
            ):
                raise
            raise self._watchdog.passed(self._request) from err
        self._check(size)  # a body cut by the watchdog may end "cleanly" (no Content-Length)

    def _check(self, size: int) -> None:
        if self._watchdog.expired.is_set():
            raise self._watchdog.passed(self._request)
        if size > self._limit:
            raise BodyTooLarge(f"body larger than {self._limit} bytes", request=self._request)

    def close(self) -> None:
        self._watchdog.cancel()
        self._inner.close()


class _Watchdog:
    """Shuts the request's socket down when its time is up. The socket comes from httpcore's
    ``trace`` extension (the TCP connection, then the TLS one wrapping it)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.expired = threading.Event()
        self._done = False
        self._sock: socket.socket | None = None
        self._lock = threading.Lock()
        self._timer = threading.Timer(seconds, self._shut)
        self._timer.daemon = True
        self._timer.start()

    def trace(self, event: str, info: dict[str, Any]) -> None:
        extra = getattr(info.get("return_value"), "get_extra_info", None)
        sock = extra("socket") if extra is not None and event.endswith(".complete") else None
        if isinstance(sock, socket.socket):
            self._sock = sock
            if self.expired.is_set():
                self._shut()

    def passed(self, request: httpx.Request) -> DeadlinePassed:
        return DeadlinePassed(f"deadline of {self.seconds:g} s passed", request=request)

    def _shut(self) -> None:
        with self._lock:
            self.expired.set()
            if self._sock is not None and not self._done:
                with contextlib.suppress(OSError):  # the plain socket's shutdown, even under TLS
                    socket.socket.shutdown(self._sock, socket.SHUT_RDWR)

    def cancel(self) -> None:
        with self._lock:
            self._done = True
        self._timer.cancel()
