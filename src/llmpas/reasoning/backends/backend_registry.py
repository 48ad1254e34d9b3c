"""LLM backends from a spec string, built in one place (:func:`make_backend`).

:data:`KINDS` is the registry of every ``--llm`` kind: its name (the spec before the colon), how
it is written, one line of help and its maker. It is the single source of the choices the
command line offers (:func:`choices`) and of the table in ``docs/llm-part.md``
(:func:`markdown_table`). The registry is lazy: a maker imports its backend's module only when
a spec of its kind is built. ``oracle`` (a labelled oracle, which reads the world's truth:
:mod:`llmpas.reasoning.truth_oracle`) and ``replan`` (no LLM: the task restated:
:mod:`llmpas.reasoning.replan`), the recovery methods that ask no model, have no maker here: the
product's registry supplies them (:func:`llmpas.system.catalog.llm_for`), since reasoning knows
no world.

``record``: a cassette folder the answers are recorded into (replayed when present). Bad specs
raise :class:`ValueError` naming the spec; nothing is loaded before the spec is known good.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

from llmpas.reasoning.llm import LLM
from llmpas.reasoning.replan import REPLAN
from llmpas.reasoning.truth_oracle import ORACLE

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
    timeout = _timeout(os.environ.get(TIMEOUT_VARIABLE))
    backend = OpenAIBackend(model, base_url=base_url or None, timeout=timeout)
    return _recorded(backend, record)


TIMEOUT_VARIABLE = "LLMPAS_LLM_TIMEOUT"  # seconds per request of an HTTP backend
DEFAULT_TIMEOUT = 30.0


def _timeout(value: str | None) -> float:
    if value is None or not value.strip():
        return DEFAULT_TIMEOUT
    try:
        seconds = float(value)
    except ValueError:
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"{TIMEOUT_VARIABLE}={value!r}: expected a positive number of seconds")
    return seconds


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


@dataclass(frozen=True)
class BackendKind:
    """One kind of ``--llm`` spec. ``maker``: builds it (None: the caller supplies the maker,
    as the experiments do for ``oracle`` and ``replan``)."""

    name: str
    syntax: str
    help: str
    maker: Maker | None = None

    def __post_init__(self) -> None:
        if not self.name or ":" in self.name:
            raise ValueError(f"a backend kind's name is a word without ':', got {self.name!r}")
        if not self.syntax.startswith(self.name):
            raise ValueError(f"{self.name}: its syntax must start with its name: {self.syntax!r}")


KINDS: Mapping[str, BackendKind] = MappingProxyType(
    {
        k.name: k
        for k in (
            BackendKind(
                ORACLE,
                ORACLE,
                "the labelled oracle: reads the truth (an upper bound, never a default)",
            ),
            BackendKind(REPLAN, REPLAN, "no LLM: the task restated (the baseline)"),
            BackendKind("replay", "replay:DIR", "answers recorded in a cassette folder", _replay),
            BackendKind(
                "openai",
                "openai:MODEL[@BASE_URL]",
                f"an OpenAI-compatible endpoint (key: OPENAI_API_KEY; {TIMEOUT_VARIABLE})",
                _openai,
            ),
            BackendKind(
                "llama-cpp",
                "llama-cpp[:PATH]",
                "a local GGUF model (default: the offline model)",
                _llama_cpp,
            ),
        )
    }
)
"""Every ``--llm`` kind, in the order the command line lists them."""

BACKENDS: Mapping[str, Maker] = MappingProxyType(
    {name: k.maker for name, k in KINDS.items() if k.maker is not None}
)
"""The kinds built here (the LLMs proper)."""


def choices(names: Iterable[str] | None = None, shown: Mapping[str, str] = {}) -> str:
    """``oracle | replay:DIR | ...``: the kinds ``names`` (default: all), as written, in the
    registry's order (``shown``: another text for a kind, e.g. what the oracle is there)."""
    wanted = set(KINDS) if names is None else set(names)
    unknown = sorted(wanted - set(KINDS))
    if unknown:
        raise ValueError(f"unknown backend kind {unknown[0]!r}; kinds: {', '.join(KINDS)}")
    return " | ".join(shown.get(n, k.syntax) for n, k in KINDS.items() if n in wanted)


SPECS = choices((ORACLE, *BACKENDS))
"""What a spec may be where the oracle is offered (no replan)."""


def markdown_table() -> str:
    """The registry as the Markdown table of ``docs/llm-part.md``."""
    lines = ["| `--llm` | what it is |", "|---|---|"]
    lines += [f"| `{k.syntax}` | {k.help} |" for k in KINDS.values()]
    return "\n".join(lines) + "\n"


def make_backend(spec: str, record: str | None = None, extra: Mapping[str, Maker] = {}) -> Any:
    """The backend for ``spec`` (``extra``: makers of the kinds the caller supplies, e.g.
    ``oracle``). ValueError naming the spec when it is not one of the kinds buildable here or
    its argument is missing."""
    kind, _, arg = spec.partition(":")
    makers = {**BACKENDS, **extra}
    if kind not in makers:
        offered = [n for n in KINDS if n in makers or n == ORACLE]
        raise ValueError(f"{spec!r}: expected {choices(offered)}")
    try:
        return makers[kind](arg, record)
    except ValueError as err:
        raise ValueError(f"{spec}: {err}") from None


def add_llm_argument(
    p: argparse.ArgumentParser, oracle: str = ORACLE, replan: bool = False
) -> None:
    """The ``--llm`` option of ``llmpas run`` and of every experiment, its choices from the
    registry (``oracle`` says what the oracle is there; ``replan``: the no-LLM baseline is
    offered too)."""
    kinds = [ORACLE, *([REPLAN] if replan else []), *BACKENDS]
    shown = {REPLAN: "replan (no LLM: the task restated)", ORACLE: oracle}
    p.add_argument(
        "--llm",
        default="llama-cpp",
        help=f"{choices(kinds, shown)} (default: the offline model)",
    )


__all__ = [
    "BACKENDS",
    "KINDS",
    "SPECS",
    "BackendKind",
    "Maker",
    "add_llm_argument",
    "choices",
    "make_backend",
    "markdown_table",
]
