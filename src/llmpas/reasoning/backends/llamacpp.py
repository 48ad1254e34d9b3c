"""A local GGUF model through ``llama-cpp-python``, run in a worker process of its own.

llama.cpp is native code: when it crashes (a segmentation fault, an abort, an out-of-memory
kill), only the worker dies; the request ends as one :class:`LLMError` line naming the backend
and the signal, and the caller's run keeps what it has. Each request has a deadline (the worker
is killed past it) and a size bound on the answer; the worker is stopped by :meth:`close`, by
``with``, when the backend is garbage collected or the interpreter exits, and it exits by itself
when its parent is gone. A dead worker is restarted at the next request.
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import IO, Any

from llmpas.reasoning.llm import LLMError, Message, Request, Response, ScoreRequest, Scores

log = logging.getLogger(__name__)

INSTALL_HINT = "pip install 'llmpas[llm]' (or pip install llama-cpp-python)"
WORKER = "llmpas.reasoning.backends.llamacpp_worker"
MAX_MESSAGE = 8 * 1024 * 1024  # bytes of one answer from the worker
STDERR_TAIL = 300  # characters of the worker's stderr quoted when it dies


@dataclass(frozen=True)
class LlamaSettings:
    """How the worker loads the model. ``extra_bufts``: let llama.cpp repack weights into its
    extra buffer types (AMX, ...); off by default, since the AMX path crashes on some CPUs."""

    n_ctx: int = 4096
    n_threads: int = 1
    seed: int = 0
    extra_bufts: bool = False
    load_timeout: float = 300.0  # seconds to load the model
    timeout: float = 600.0  # seconds for one answer

    def __post_init__(self) -> None:
        if self.n_ctx < 1 or self.n_threads < 1:
            raise ValueError(f"n_ctx, n_threads must be >= 1, got {self.n_ctx}, {self.n_threads}")
        if not (self.load_timeout > 0 and self.timeout > 0):
            raise ValueError("load_timeout and timeout must be > 0 seconds")


class LlamaCppBackend:
    """A local chat model; ``request.grammar`` (GBNF) constrains decoding exactly.

    ``n_threads`` defaults to 1: with 2 threads generation collapses when the other core is busy.
    """

    def __init__(
        self,
        model_path: str | os.PathLike[str],
        n_ctx: int = 4096,
        n_threads: int = 1,
        seed: int = 0,
        settings: LlamaSettings | None = None,
    ) -> None:
        self.model_path = Path(model_path)
        self.settings = settings or LlamaSettings(n_ctx=n_ctx, n_threads=n_threads, seed=seed)
        self.seed = self.settings.seed
        self.name = f"llama-cpp:{self.model_path.stem}"
        if not self.model_path.is_file():
            raise LLMError(f"model file {self.model_path} not found: run `llmpas model install`")
        if importlib.util.find_spec("llama_cpp") is None:
            raise LLMError(f"llama-cpp-python is not installed: {INSTALL_HINT}")
        self._lock = threading.Lock()
        self._worker: _Worker | None = None
        self._requests = 0
        self._start()

    def __repr__(self) -> str:
        return f"LlamaCppBackend({str(self.model_path)!r})"

    def __enter__(self) -> LlamaCppBackend:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def pid(self) -> int | None:
        """The worker's process id (None when it is not running)."""
        worker = self._worker
        return worker.process.pid if worker is not None and worker.alive() else None

    def close(self) -> None:
        """Stop the worker (a later request starts a new one)."""
        worker, self._worker = self._worker, None
        if worker is not None:
            worker.stop()

    def complete(self, request: Request) -> Response:
        if not self._lock.acquire(blocking=False):
            # an earlier call was abandoned (a caller's deadline) and still waits: end it
            self.close()
            if not self._lock.acquire(timeout=self.settings.timeout):
                raise LLMError(f"{self.name}: the model's process is busy with another request")
        try:
            return self._complete(request)
        finally:
            self._lock.release()

    def _complete(self, request: Request) -> Response:
        worker = self._worker
        if worker is None or not worker.alive():
            worker = self._start()
        self._requests += 1
        message = {"id": self._requests, "complete": _kwargs(request, self.seed)}
        start = time.perf_counter()
        try:
            answer = worker.ask(message, self.settings.timeout, "answering")
        except BaseException:
            if self._worker is worker:
                self.close()
            raise
        latency = time.perf_counter() - start
        if answer.get("id") != message["id"]:
            self.close()
            raise LLMError(f"{self.name}: the model's process answered another request")
        if "error" in answer:
            raise LLMError(f"{self.name}: {answer['error']}")
        ok = answer["ok"]
        return Response(
            text=str(ok.get("text") or ""),
            model=self.name,
            prompt_tokens=int(ok.get("prompt_tokens") or 0),
            completion_tokens=int(ok.get("completion_tokens") or 0),
            latency=latency,
            meta={"finish_reason": ok.get("finish_reason")},
        )

    def score(self, request: ScoreRequest) -> Scores:
        """Each choice's token log-probabilities after the chat and the prefix (a request kind
        of its own beside :meth:`complete`; the worker answers ``score`` messages)."""
        with self._lock:
            worker = self._worker
            if worker is None or not worker.alive():
                worker = self._start()
            self._requests += 1
            message = {
                "id": self._requests,
                "score": {
                    "messages": [{"role": m.role, "content": m.content} for m in request.messages],
                    "prefix": request.prefix,
                    "choices": list(request.choices),
                },
            }
            start = time.perf_counter()
            try:
                answer = worker.ask(message, self.settings.timeout, "scoring")
            except BaseException:
                if self._worker is worker:
                    self.close()
                raise
            if answer.get("id") != message["id"]:
                self.close()
                raise LLMError(f"{self.name}: the model's process answered another request")
            if "error" in answer:
                raise LLMError(f"{self.name}: {answer['error']}")
            ok = answer["ok"]
            return Scores(
                tuple(tuple(float(x) for x in lp) for lp in ok["logprobs"]),
                model=self.name,
                prompt_tokens=int(ok.get("prompt_tokens") or 0),
                latency=time.perf_counter() - start,
            )

    def _start(self) -> _Worker:
        self.close()
        start = time.perf_counter()
        worker = _Worker(self.name)
        load = {
            "model_path": str(self.model_path),
            "n_ctx": self.settings.n_ctx,
            "n_threads": self.settings.n_threads,
            "seed": self.settings.seed,
            "extra_bufts": self.settings.extra_bufts,
        }
        try:
            answer = worker.ask({"load": load}, self.settings.load_timeout, "loading the model")
        except BaseException:
            worker.stop()
            raise
        if "error" in answer:
            worker.stop()
            raise LLMError(f"cannot load {self.model_path}: {answer['error']}")
        self._worker = worker
        log.info("loaded %s in %.2f s", self.model_path.name, time.perf_counter() - start)
        return worker


class _Worker:
    """One worker process and its socket; a finalizer kills it if nobody stops it."""

    def __init__(self, name: str) -> None:
        self.name = name
        ours, theirs = socket.socketpair()
        self._stderr: IO[bytes] = tempfile.TemporaryFile(prefix="llmpas-llama-")  # noqa: SIM115
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-m", WORKER, str(theirs.fileno())],
                pass_fds=(theirs.fileno(),),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,  # native code may print: never on the protocol
                stderr=self._stderr,
            )
        except OSError as err:
            ours.close()
            self._stderr.close()
            raise LLMError(f"{name}: cannot start the model's process: {err}") from None
        finally:
            theirs.close()
        self.conn = Connection(ours.detach())
        self._finalizer = weakref.finalize(self, _kill, self.process, self.conn, self._stderr)

    def alive(self) -> bool:
        return self.process.poll() is None

    def stop(self) -> None:
        self._finalizer()

    def ask(self, message: dict[str, Any], timeout: float, doing: str) -> dict[str, Any]:
        """Send ``message`` and wait for the answer, at most ``timeout`` seconds."""
        try:
            self.conn.send_bytes(json.dumps(message).encode("ascii"))
            if not wait([self.conn], timeout):
                self.stop()
                raise LLMError(f"{self.name}: no answer within {timeout:g} s ({doing}); stopped")
            data = self.conn.recv_bytes(MAX_MESSAGE)
        except (EOFError, OSError) as err:
            raise self._died(doing, err) from None
        try:
            answer = json.loads(data)
        except ValueError:
            answer = None
        if not isinstance(answer, dict):
            self.stop()
            raise LLMError(f"{self.name}: the model's process sent a malformed message")
        return answer

    def _died(self, doing: str, err: BaseException) -> LLMError:
        """The one-line error for a worker that stopped answering."""
        try:
            code = self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:  # alive but the message was too large or cut
            self.stop()
            return LLMError(f"{self.name}: bad message from the model's process ({err}); stopped")
        tail = self._stderr_tail()
        self.stop()
        what = died(code, self.process.pid)
        return LLMError(
            f"{self.name}: {what} while {doing}{tail}; `llmpas doctor` checks the model"
        )

    def _stderr_tail(self) -> str:
        try:
            self._stderr.seek(0, os.SEEK_END)
            size = self._stderr.tell()
            self._stderr.seek(max(0, size - 4 * STDERR_TAIL))
            text = self._stderr.read().decode("utf-8", "replace")
        except (OSError, ValueError):
            return ""
        lines = [line.strip() for line in text.splitlines() if line.strip()]
        return f" (it said: {lines[-1][-STDERR_TAIL:]})" if lines else ""


def died(code: int, pid: int) -> str:
    """How a process ended, in words: ``was killed by SIGSEGV (segmentation fault)``."""
    if code >= 0:
        return f"the model's process (pid {pid}) exited with status {code}"
    try:
        sig = signal.Signals(-code)
    except ValueError:
        return f"the model's process (pid {pid}) was killed by signal {-code}"
    what = (signal.strsignal(sig) or sig.name).lower()
    oom = ", out of memory?" if sig is signal.SIGKILL else ""
    return f"the model's process (pid {pid}) was killed by {sig.name} ({what}{oom})"


def _kill(process: subprocess.Popen[bytes], conn: Connection, stderr: IO[bytes]) -> None:
    conn.close()
    if process.poll() is None:
        process.kill()
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        log.warning("the model's process %d did not stop", process.pid)
    stderr.close()


def _kwargs(request: Request, seed: int) -> dict[str, Any]:
    kwargs: dict[str, Any] = {
        "messages": [{"role": m.role, "content": m.content} for m in request.messages],
        "temperature": request.temperature,
        "max_tokens": request.max_tokens,
        "seed": seed if request.seed is None else request.seed,
    }
    if request.grammar is not None:
        kwargs["grammar"] = request.grammar
    elif request.json_schema is not None:
        kwargs["response_format"] = {"type": "json_object", "schema": dict(request.json_schema)}
    return kwargs


@dataclass(frozen=True)
class SelfTest:
    """What decoding a few tokens in a worker gave: ``ok``, and one line saying what happened."""

    ok: bool
    message: str


def self_test(model_path: str | os.PathLike[str], timeout: float = 300.0) -> SelfTest:
    """Load ``model_path`` in a worker and decode a few tokens (a crash costs only the worker)."""
    settings = LlamaSettings(n_ctx=512, load_timeout=timeout, timeout=timeout)
    request = Request((Message("user", "Say OK."),), max_tokens=4)
    try:
        with LlamaCppBackend(model_path, settings=settings) as llm:
            start = time.perf_counter()
            answer = llm.complete(request)
    except LLMError as err:
        return SelfTest(False, str(err))
    seconds = time.perf_counter() - start
    return SelfTest(True, f"decoded {answer.completion_tokens} tokens in {seconds:.1f} s")
