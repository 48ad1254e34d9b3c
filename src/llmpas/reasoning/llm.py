"""What the reasoner needs from a language model: one small Protocol and its value types.

Backends (``openai``, ``llama-cpp``, ``replay``, ``oracle``) implement :class:`LLM`. A request is
plain data (messages plus optional decoding constraints), so it can be hashed, recorded and
replayed; a response records text, token usage and latency. LLM output is data: it is parsed,
never executed.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from types import MappingProxyType
from typing import Any, Literal, Protocol, runtime_checkable

Role = Literal["system", "user", "assistant"]


@dataclass(frozen=True)
class Message:
    role: Role
    content: str

    def __post_init__(self) -> None:
        if self.role not in ("system", "user", "assistant"):
            raise ValueError(f"message role must be system/user/assistant, got {self.role!r}")


@dataclass(frozen=True)
class Request:
    """One chat completion request.

    ``grammar``: a GBNF grammar (llama.cpp) constraining the output; ``json_schema``: a JSON
    schema (OpenAI structured outputs). Backends use whichever they support.
    """

    messages: tuple[Message, ...]
    temperature: float = 0.0
    max_tokens: int = 512
    seed: int | None = None
    grammar: str | None = None
    json_schema: Mapping[str, Any] | None = None
    tag: str = ""  # what the request is for (e.g. "flp-step1"); not part of the key
    # what the prompt was made from (the anomaly as data, for backends that read it, such as a
    # labelled oracle); not part of the key, never sent
    situation: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not self.messages:
            raise ValueError("a request needs at least one message")
        if not 0.0 <= self.temperature <= 2.0:
            raise ValueError(f"temperature must be in [0, 2], got {self.temperature}")
        if self.max_tokens < 1:
            raise ValueError(f"max_tokens must be >= 1, got {self.max_tokens}")
        if self.json_schema is not None:
            object.__setattr__(self, "json_schema", MappingProxyType(dict(self.json_schema)))

    def key(self) -> str:
        """A stable hash of everything that determines the answer (for record/replay)."""
        data = {
            "messages": [[m.role, m.content] for m in self.messages],
            "temperature": self.temperature,
            "max_tokens": self.max_tokens,
            "seed": self.seed,
            "grammar": self.grammar,
            "json_schema": _plain(self.json_schema),
        }
        text = json.dumps(data, sort_keys=True, ensure_ascii=False)
        # surrogatepass: a prompt quoting an answer with lone surrogates still has a key
        return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()


def _plain(x: Any) -> Any:
    if isinstance(x, Mapping):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    return x


@dataclass(frozen=True)
class Response:
    text: str
    model: str = ""
    prompt_tokens: int = 0
    completion_tokens: int = 0
    latency: float = 0.0  # seconds
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))


@dataclass(frozen=True)
class ScoreRequest:
    """Score given continuations of one chat: how likely the model finds each ``choice`` as
    the start of its answer (after ``prefix``, text the answer is taken to begin with). A
    request kind of its own beside :class:`Request`, recorded and replayed the same way."""

    messages: tuple[Message, ...]
    choices: tuple[str, ...]
    prefix: str = ""
    tag: str = ""  # not part of the key
    situation: Any = field(default=None, compare=False, repr=False)  # never sent

    def __post_init__(self) -> None:
        if not self.messages:
            raise ValueError("a score request needs at least one message")
        if not self.choices or any(not c for c in self.choices):
            raise ValueError("a score request needs non-empty choices")

    def key(self) -> str:
        data = {
            "kind": "score",
            "messages": [[m.role, m.content] for m in self.messages],
            "choices": list(self.choices),
            "prefix": self.prefix,
        }
        text = json.dumps(data, sort_keys=True, ensure_ascii=False)
        return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()


@dataclass(frozen=True)
class Scores:
    """The log-probability of each choice's tokens (natural log, one list per choice)."""

    logprobs: tuple[tuple[float, ...], ...]
    model: str = ""
    prompt_tokens: int = 0
    latency: float = 0.0

    def mean(self) -> tuple[float, ...]:
        """Per choice, the mean log-probability of its tokens (length-normalised, so that a
        conjunction is not ranked below a literal for its length alone)."""
        return tuple(sum(lp) / len(lp) if lp else float("-inf") for lp in self.logprobs)


@runtime_checkable
class Scorer(Protocol):
    """A backend that can score continuations (token log-probabilities)."""

    name: str

    def score(self, request: ScoreRequest) -> Scores: ...


class LLMError(RuntimeError):
    """A backend could not answer (timeout, HTTP error, missing model): one line saying why."""


class Fault(Enum):
    """What went wrong talking to an LLM server."""

    TIMEOUT = "timeout"
    CONNECTION = "connection"
    HTTP = "http"  # a non-2xx status
    MALFORMED = "malformed"  # not JSON, not UTF-8, or not a chat completion
    TOO_LARGE = "too-large"  # the answer exceeds the size bound


class ScoringUnsupported(LLMError):
    """The backend cannot score continuations (the caller asks for a numbered choice)."""


class LLMServerError(LLMError):
    """An LLM server failed: ``fault`` says how, ``server`` names it (``host:port`` and model);
    the message is one line, with any secret redacted."""

    def __init__(self, server: str, fault: Fault, reason: str, status: int | None = None) -> None:
        super().__init__(f"{server}: {reason}")
        self.server = server
        self.fault = fault
        self.reason = reason
        self.status = status


@runtime_checkable
class LLM(Protocol):
    """A chat model. ``complete`` raises :class:`LLMError` when it cannot answer."""

    name: str

    def complete(self, request: Request) -> Response: ...


@runtime_checkable
class Baseline(Protocol):
    """An answerer in the LLM's place that is no LLM (the ``replan`` baseline restates the
    task): ``role`` says what it is wherever the records would say "the LLM"; the loop asks it
    for at most ``repairs`` repairs (its answer does not depend on the errors shown)."""

    name: str
    role: str
    repairs: int

    def complete(self, request: Request) -> Response: ...
