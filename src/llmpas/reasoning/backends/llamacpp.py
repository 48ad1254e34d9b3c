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
from collections.abc import Callable, Collection
from dataclasses import dataclass, replace
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import IO, Any

from llmpas.reasoning.llm import LLMError, Message, Request, Response, ScoreRequest, Scores

log = logging.getLogger(__name__)

INSTALL_HINT = "pip install 'llmpas[llm]' (or pip install llama-cpp-python)"
WORKER = "llmpas.reasoning.backends.llamacpp_worker"
MAX_MESSAGE = 8 * 1024 * 1024  # bytes of one answer from the worker
STDERR_TAIL = 300  # characters of the worker's stderr quoted when it dies


JOBS_VARIABLE = "LLMPAS_JOBS"  # how many jobs share this machine's cores (set by --jobs)
KV_STATES = 8  # KV states kept by default (~28 kB a token each for the 1.5B model)


IDLE_SAMPLE = 0.3  # seconds of /proc/stat the free cores are read from
PROC_STAT = Path("/proc/stat")


def _read_proc_stat() -> str:
    return PROC_STAT.read_text(encoding="ascii", errors="replace")


def idle_cores(
    cpus: Collection[int],
    read: Callable[[], str] = _read_proc_stat,
    sleep: Callable[[float], None] = time.sleep,
    seconds: float = IDLE_SAMPLE,
) -> float | None:
    """How many of ``cpus`` were idle over the last ``seconds`` (a fraction of each, summed):
    two readings of the kernel's per-CPU time counters (``/proc/stat``, idle and iowait against
    all), ``seconds`` apart. What is free now, where the 1-minute load average still counts a
    job that ended half a minute ago (started right after one, the offline model got one thread
    and took 57 s of LLM time where a quiet machine took 40). None where the counters cannot be
    read (not Linux) or did not move."""
    try:
        before = _cpu_times(read())
        sleep(seconds)
        after = _cpu_times(read())
    except (OSError, ValueError):
        return None
    idle = 0.0
    counted = 0
    for cpu in cpus:
        if cpu not in before or cpu not in after:
            continue
        (idle0, total0), (idle1, total1) = before[cpu], after[cpu]
        if total1 > total0:
            idle += min(1.0, max(0.0, (idle1 - idle0) / (total1 - total0)))
            counted += 1
    return idle if counted else None


def _cpu_times(text: str) -> dict[int, tuple[int, int]]:
    """Per CPU of ``/proc/stat``: (idle + iowait, all) jiffies."""
    out = {}
    for line in text.splitlines():
        name, *fields = line.split() or [""]
        if not name.startswith("cpu") or name == "cpu" or not fields:
            continue
        ticks = [int(f) for f in fields[:8]]  # guest times are in user's already
        if len(ticks) < 4:
            raise ValueError(f"/proc/stat: short line {line!r}")
        out[int(name[3:])] = (ticks[3] + (ticks[4] if len(ticks) > 4 else 0), sum(ticks))
    return out


def free_cores(
    jobs: int | None = None, sample: Callable[[Collection[int]], float | None] = idle_cores
) -> int:
    """This process's share of the cores nobody else is using: the idle share of the cores it
    may run on, sampled now (:func:`idle_cores`; where it cannot be read, the cores less the
    load of the last minute), divided among ``jobs`` (default: ``$LLMPAS_JOBS``, else 1); at
    least 1. Another job's busy thread makes a llama.cpp thread wait for it: with the other
    core busy, 2 threads generated 0.3 tokens/s where 1 made 12."""
    if jobs is None:
        value = os.environ.get(JOBS_VARIABLE, "")
        jobs = int(value) if value.isdigit() and int(value) > 0 else 1
    cpus = (
        set(os.sched_getaffinity(0))
        if hasattr(os, "sched_getaffinity")
        else set(range(os.cpu_count() or 1))
    )
    cores = len(cpus) or 1
    idle = sample(cpus)
    if idle is None:
        busy = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
        idle = cores - busy
    return max(1, int(min(cores, idle) + 0.5) // max(1, jobs))


@dataclass(frozen=True)
class LlamaSettings:
    """How the worker loads the model. ``extra_bufts``: let llama.cpp repack weights into its
    extra buffer types (AMX, ...); off by default, since the AMX path crashes on some CPUs.
    ``n_threads``: 0 (the default) decides when the model loads, from the cores idle then
    (:func:`free_cores`); a restarted worker decides again. ``kv_states``: KV
    states kept across answers, so that no prompt prefix is evaluated twice (0: only the state
    of the last answer, as llama-cpp-python keeps it)."""

    n_ctx: int = 4096
    n_threads: int = 0
    seed: int = 0
    extra_bufts: bool = False
    kv_states: int = KV_STATES
    load_timeout: float = 300.0  # seconds to load the model
    timeout: float = 600.0  # seconds for one answer

    def __post_init__(self) -> None:
        if self.n_ctx < 1 or self.n_threads < 0:
            raise ValueError(
                f"n_ctx must be >= 1, n_threads >= 0, got {self.n_ctx}, {self.n_threads}"
            )
        if self.kv_states < 0:
            raise ValueError(f"kv_states must be >= 0, got {self.kv_states}")
        if not (self.load_timeout > 0 and self.timeout > 0):
            raise ValueError("load_timeout and timeout must be > 0 seconds")


def settings_before(settings: LlamaSettings | None = None) -> LlamaSettings:
    """``settings`` (default: the defaults) as they were before #30: one thread, only the
    last answer's KV state kept."""
    return replace(settings or LlamaSettings(), n_threads=1, kv_states=0)


class LlamaCppBackend:
    """A local chat model; ``request.grammar`` (GBNF) constrains decoding exactly.

    ``n_threads`` defaults to the cores free when the model loads (:func:`free_cores`; the
    number used is :attr:`threads`): with 2 threads generation collapses when the other core
    is busy. A response's ``meta`` says how many prompt tokens
    were evaluated and reused, and the seconds of the prompt and of the whole answer.
    """

    def __init__(
        self,
        model_path: str | os.PathLike[str],
        n_ctx: int = 4096,
        n_threads: int | None = None,
        seed: int = 0,
        settings: LlamaSettings | None = None,
    ) -> None:
        self.model_path = Path(model_path)
        if settings is None:
            settings = LlamaSettings(n_ctx=n_ctx, seed=seed)
            if n_threads is not None:
                settings = replace(settings, n_threads=n_threads)
        self.settings = settings
        self.seed = self.settings.seed
        self.name = f"llama-cpp:{self.model_path.stem}"
        if not self.model_path.is_file():
            raise LLMError(f"model file {self.model_path} not found: run `llmpas model install`")
        if importlib.util.find_spec("llama_cpp") is None:
            raise LLMError(f"llama-cpp-python is not installed: {INSTALL_HINT}")
        self._lock = threading.Lock()
        self._worker: _Worker | None = None
        self._requests = 0
        self.threads = self.settings.n_threads  # the worker's threads (decided when it loads)
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
        ok, latency = self.ask("complete", request_kwargs(request, self.seed))
        return _response(self.name, ok, latency)

    def ask(self, kind: str, body: dict[str, Any]) -> tuple[dict[str, Any], float]:
        """One request of ``kind`` (a key of the worker's ``REQUESTS``) to the worker: its
        answer's ``ok`` object and the seconds it took; an :class:`LLMError` when it failed."""
        if not self._lock.acquire(blocking=False):
            self.close()  # an abandoned call still waits: end it
            if not self._lock.acquire(timeout=self.settings.timeout):
                raise LLMError(f"{self.name}: the model's process is busy with another request")
        try:
            return self._ask(kind, body)
        finally:
            self._lock.release()

    def _ask(self, kind: str, body: dict[str, Any]) -> tuple[dict[str, Any], float]:
        worker = self._worker
        if worker is None or not worker.alive():
            worker = self._start()
        self._requests += 1
        message = {"id": self._requests, kind: body}
        start = time.perf_counter()
        try:
            answer = worker.ask(message, self.settings.timeout, "answering")
        except BaseException:
            if self._worker is worker:
                self.close()
            raise
        seconds = time.perf_counter() - start
        if answer.get("id") != message["id"]:
            self.close()
            raise LLMError(f"{self.name}: the model's process answered another request")
        if "error" in answer:
            raise LLMError(f"{self.name}: {answer['error']}")
        ok = answer.get("ok")
        if not isinstance(ok, dict):
            self.close()
            raise LLMError(f"{self.name}: the model's process sent a malformed message")
        return ok, seconds

    def score(self, request: ScoreRequest) -> Scores:
        """Each choice's token log-probabilities after the chat and the prefix (a request kind
        of its own beside :meth:`complete`; the worker answers ``score`` messages)."""
        body = {
            "messages": [{"role": m.role, "content": m.content} for m in request.messages],
            "prefix": request.prefix,
            "choices": list(request.choices),
        }
        ok, seconds = self.ask("score", body)
        return Scores(
            tuple(tuple(float(x) for x in lp) for lp in ok["logprobs"]),
            model=self.name,
            prompt_tokens=int(ok.get("prompt_tokens") or 0),
            latency=seconds,
        )

    def _start(self) -> _Worker:
        self.close()
        start = time.perf_counter()
        self.threads = self.settings.n_threads or free_cores()
        worker = _Worker(self.name)
        load = {
            "model_path": str(self.model_path),
            "n_ctx": self.settings.n_ctx,
            "n_threads": self.threads,
            "seed": self.settings.seed,
            "extra_bufts": self.settings.extra_bufts,
            "kv_states": self.settings.kv_states,
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
        seconds = time.perf_counter() - start
        log.info("loaded %s in %.2f s, %d threads", self.model_path.name, seconds, self.threads)
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
                # a process group of its own: a terminal's Ctrl-C reaches the caller only, also
                # while the worker starts (before it ignores SIGINT, Ctrl-C killed it: an LLM
                # error instead of an interrupted run); the caller stops it
                process_group=0,
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


def _response(name: str, ok: dict[str, Any], latency: float) -> Response:
    return Response(
        text=str(ok.get("text") or ""),
        model=name,
        prompt_tokens=int(ok.get("prompt_tokens") or 0),
        completion_tokens=int(ok.get("completion_tokens") or 0),
        latency=latency,
        meta={"finish_reason": ok.get("finish_reason"), **_measured(ok)},
    )


MEASURED = ("prompt_evaluated", "prompt_reused", "prompt_seconds", "seconds")


def _measured(ok: dict[str, Any]) -> dict[str, float]:
    """What the worker measured of one answer (numbers only)."""
    return {k: v for k in MEASURED if isinstance(v := ok.get(k), int | float)}


def request_kwargs(request: Request, seed: int) -> dict[str, Any]:
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
