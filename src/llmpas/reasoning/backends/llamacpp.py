"""An in-process GGUF model through ``llama-cpp-python`` (imported lazily)."""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path
from typing import Any

from llmpas.reasoning.llm import LLMError, Request, Response

log = logging.getLogger(__name__)

INSTALL_HINT = "pip install 'llmpas[llm]' (or pip install llama-cpp-python)"


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
    ) -> None:
        self.model_path = Path(model_path)
        self.seed = seed
        self.name = f"llama-cpp:{self.model_path.stem}"
        if not self.model_path.is_file():
            raise LLMError(f"model file {self.model_path} not found: run `llmpas model install`")
        llama_cpp = _import_llama_cpp()
        start = time.perf_counter()
        try:
            self._llama = llama_cpp.Llama(
                model_path=str(self.model_path),
                n_ctx=n_ctx,
                n_threads=n_threads,
                seed=seed,
                verbose=False,
            )
        except (ValueError, RuntimeError) as err:
            raise LLMError(f"cannot load {self.model_path}: {err}") from None
        log.info("loaded %s in %.2f s", self.model_path.name, time.perf_counter() - start)

    def __repr__(self) -> str:
        return f"LlamaCppBackend({str(self.model_path)!r})"

    def complete(self, request: Request) -> Response:
        kwargs = self._kwargs(request)
        start = time.perf_counter()
        try:
            out = self._llama.create_chat_completion(**kwargs)
        except (ValueError, RuntimeError) as err:
            raise LLMError(f"{self.name}: {' '.join(str(err).split())}") from None
        latency = time.perf_counter() - start
        usage = out.get("usage") or {}
        choice = out["choices"][0]
        return Response(
            text=choice["message"].get("content") or "",
            model=self.name,
            prompt_tokens=usage.get("prompt_tokens", 0),
            completion_tokens=usage.get("completion_tokens", 0),
            latency=latency,
            meta={"finish_reason": choice.get("finish_reason")},
        )

    def _kwargs(self, request: Request) -> dict[str, Any]:
        kwargs: dict[str, Any] = {
            "messages": [{"role": m.role, "content": m.content} for m in request.messages],
            "temperature": request.temperature,
            "max_tokens": request.max_tokens,
            "seed": self.seed if request.seed is None else request.seed,
        }
        if request.grammar is not None:
            self._check_grammar(request.grammar)
            kwargs["grammar"] = _grammar(request.grammar)
        elif request.json_schema is not None:
            schema = dict(request.json_schema)
            kwargs["response_format"] = {"type": "json_object", "schema": schema}
        return kwargs

    def _check_grammar(self, text: str) -> None:
        """Parse ``text`` with llama.cpp's own GBNF parser first: ``LlamaGrammar.from_string``
        only stores the string, and a grammar llama.cpp cannot parse gives a NULL sampler that
        crashes the process (segmentation fault) at the first sampled token."""
        llama_cpp = _import_llama_cpp()
        vocab = llama_cpp.llama_model_get_vocab(self._llama.model)
        sampler = llama_cpp.llama_sampler_init_grammar(vocab, text.encode("utf-8"), b"root")
        if not sampler:
            shown = " ".join(text.split())[:80]
            raise LLMError(f"{self.name}: invalid GBNF grammar (llama.cpp cannot parse {shown!r})")
        llama_cpp.llama_sampler_free(sampler)


def _import_llama_cpp() -> Any:
    try:
        import llama_cpp
    except ImportError:
        raise LLMError(f"llama-cpp-python is not installed: {INSTALL_HINT}") from None
    return llama_cpp


def _grammar(text: str) -> Any:
    llama_cpp = _import_llama_cpp()
    try:
        return llama_cpp.LlamaGrammar.from_string(text, verbose=False)
    except (ValueError, RuntimeError) as err:
        raise LLMError(f"invalid GBNF grammar: {' '.join(str(err).split())}") from None
