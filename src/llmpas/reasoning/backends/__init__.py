"""LLM backends implementing :class:`llmpas.reasoning.llm.LLM`.

- :class:`OpenAIBackend`: any OpenAI-compatible HTTP server (OpenAI, ``llama_cpp.server``, vLLM);
- :class:`LlamaCppBackend`: a local GGUF model through ``llama-cpp-python`` (in a worker process);
- :class:`ReplayBackend`: record/replay cassettes keyed by :meth:`Request.key`, for tests and CI.

Third-party packages (``openai``, ``llama_cpp``) are imported lazily, when a backend is built.
"""

from __future__ import annotations

from llmpas.reasoning.backends.llamacpp import LlamaCppBackend
from llmpas.reasoning.backends.openai_http import OpenAIBackend
from llmpas.reasoning.backends.replay import ReplayBackend, ReplayMode

__all__ = ["LlamaCppBackend", "OpenAIBackend", "ReplayBackend", "ReplayMode"]
