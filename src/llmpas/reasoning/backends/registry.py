"""LLM backends from a spec string: ``replay:DIR``, ``openai:MODEL[@BASE_URL]``,
``llama-cpp[:PATH]``, and kinds a caller registers (``oracle``: a world's labelled oracle, which
:mod:`llmpas.experiments` supplies, since it reads the world's truth).

``record``: a cassette folder the answers are recorded into (replayed when present). Bad specs
raise :class:`ValueError` naming the spec; nothing is loaded before the spec is known good.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from llmpas.reasoning.llm import LLM

SPECS = "oracle | replay:DIR | openai:MODEL[@BASE_URL] | llama-cpp[:PATH]"
Maker = Callable[[str, str | None], Any]  # (argument after the colon, record folder) -> backend


def _replay(arg: str, record: str | None) -> LLM:
    from llmpas.reasoning.backends.replay import ReplayBackend

    if not arg:
        raise ValueError("replay:DIR needs the cassette folder")
    if record:
        raise ValueError("--record does not apply to replay:DIR (it only replays)")
    return ReplayBackend(Path(arg), mode="replay")


def _openai(arg: str, record: str | None) -> LLM:
    from llmpas.reasoning.backends.openai_http import OpenAIBackend

    model, _, base_url = arg.partition("@")
    if not model:
        raise ValueError("openai:MODEL[@BASE_URL] needs a model name")
    return _recorded(OpenAIBackend(model, base_url=base_url or None), record)


def _llama_cpp(arg: str, record: str | None) -> LLM:
    from llmpas.reasoning.backends.llamacpp import LlamaCppBackend
    from llmpas.reasoning.models import DEFAULT_MODEL, model_path

    path = Path(arg) if arg else model_path(DEFAULT_MODEL)
    return _recorded(LlamaCppBackend(path), record)


def _recorded(inner: LLM, record: str | None) -> LLM:
    if not record:
        return inner
    from llmpas.reasoning.backends.replay import ReplayBackend

    return ReplayBackend(Path(record), inner=inner, mode="auto")


BACKENDS: Mapping[str, Maker] = {"replay": _replay, "openai": _openai, "llama-cpp": _llama_cpp}


def make_backend(spec: str, record: str | None = None, extra: Mapping[str, Maker] = {}) -> Any:
    """The backend for ``spec`` (``extra``: more kinds, e.g. ``oracle``). ValueError naming the
    spec when it is not one of the known kinds or its argument is missing."""
    kind, _, arg = spec.partition(":")
    makers = {**BACKENDS, **extra}
    if kind not in makers:
        raise ValueError(f"{spec!r}: expected {SPECS}")
    try:
        return makers[kind](arg, record)
    except ValueError as err:
        raise ValueError(f"{spec}: {err}") from None


__all__ = ["BACKENDS", "SPECS", "Maker", "make_backend"]
