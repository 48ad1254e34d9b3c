"""An OpenAI-compatible chat-completions backend with bounded retries."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from typing import Any

from llmpas.reasoning.llm import LLMError, Request, Response

log = logging.getLogger(__name__)

LOCAL_DUMMY_KEY = "sk-local-no-key"  # local servers (llama.cpp, vLLM) accept any key


class _Retryable(Exception):
    """A failed attempt worth retrying; ``reason`` is the one-line message for the final error."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class OpenAIBackend:
    """Chat completions over HTTP with the ``openai`` SDK.

    The SDK's own retries are disabled: timeouts, HTTP 5xx/429 and connection errors are retried
    here ``max_retries`` times with exponential backoff (``backoff``, ``2*backoff``, ...), then
    reported as a one-line :class:`LLMError`. The API key is never logged.
    """

    def __init__(
        self,
        model: str,
        base_url: str | None = None,
        api_key: str | None = None,
        timeout: float = 30.0,
        max_retries: int = 2,
        backoff: float = 0.5,
        *,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if timeout <= 0:
            raise ValueError(f"timeout must be > 0, got {timeout}")
        if max_retries < 0:
            raise ValueError(f"max_retries must be >= 0, got {max_retries}")
        self.model = model
        self.name = f"openai:{model}"
        self.timeout = timeout
        self.max_retries = max_retries
        self.backoff = backoff
        self._sleep = sleep
        self._client = _make_client(base_url, _resolve_key(api_key, base_url), timeout)
        self.base_url = str(self._client.base_url).rstrip("/")

    def __repr__(self) -> str:  # no key in here, ever
        return f"OpenAIBackend(model={self.model!r}, base_url={self.base_url!r})"

    def complete(self, request: Request) -> Response:
        attempts = self.max_retries + 1
        for attempt in range(1, attempts + 1):
            try:
                return self._attempt(request)
            except _Retryable as err:
                log.warning(
                    "%s: attempt %d/%d failed: %s", self.name, attempt, attempts, err.reason
                )
                if attempt == attempts:
                    raise LLMError(f"{self.name}: {err.reason} ({attempts} attempts)") from None
                self._sleep(self.backoff * 2 ** (attempt - 1))
        raise AssertionError("unreachable")  # pragma: no cover

    def _attempt(self, request: Request) -> Response:
        import openai

        start = time.perf_counter()
        try:
            completion = self._client.chat.completions.create(**self.create_kwargs(request))
        except openai.APITimeoutError:
            raise _Retryable(f"timed out after {self.timeout:g} s at {self.base_url}") from None
        except openai.APIConnectionError:
            raise _Retryable(f"cannot connect to {self.base_url}") from None
        except openai.APIStatusError as err:
            reason = f"HTTP {err.status_code} from {self.base_url}"
            if err.status_code >= 500 or err.status_code == 429:
                raise _Retryable(reason) from None
            raise LLMError(f"{self.name}: {reason}: {_one_line(err.message)}") from None
        latency = time.perf_counter() - start
        return _to_response(completion, self.model, latency)

    def create_kwargs(self, request: Request) -> dict[str, Any]:
        """The keyword arguments of ``chat.completions.create`` for ``request``."""
        kwargs: dict[str, Any] = {
            "model": self.model,
            "messages": [{"role": m.role, "content": m.content} for m in request.messages],
            "temperature": request.temperature,
            "max_tokens": request.max_tokens,
        }
        if request.seed is not None:
            kwargs["seed"] = request.seed
        if request.json_schema is not None:
            schema = {"name": "goals", "schema": _plain(request.json_schema), "strict": True}
            kwargs["response_format"] = {"type": "json_schema", "json_schema": schema}
        if request.grammar is not None:
            kwargs["extra_body"] = {"grammar": request.grammar}
        return kwargs


def _resolve_key(api_key: str | None, base_url: str | None) -> str:
    key = api_key or os.environ.get("OPENAI_API_KEY")
    if key:
        return key
    if base_url is not None:
        return LOCAL_DUMMY_KEY
    raise LLMError("no OpenAI API key: set OPENAI_API_KEY or pass base_url for a local server")


def _make_client(base_url: str | None, api_key: str, timeout: float) -> Any:
    try:
        import openai
    except ImportError:
        raise LLMError(
            "the openai package is not installed: pip install 'llmpas[llm]' (or pip install openai)"
        ) from None
    return openai.OpenAI(api_key=api_key, base_url=base_url, timeout=timeout, max_retries=0)


def _to_response(completion: Any, model: str, latency: float) -> Response:
    if not completion.choices:
        raise LLMError(f"openai:{model}: the server returned no choices")
    choice = completion.choices[0]
    usage = completion.usage
    return Response(
        text=choice.message.content or "",
        model=completion.model or model,
        prompt_tokens=usage.prompt_tokens if usage else 0,
        completion_tokens=usage.completion_tokens if usage else 0,
        latency=latency,
        meta={"finish_reason": choice.finish_reason},
    )


def _plain(x: Any) -> Any:
    """Mappings (e.g. the read-only schema of a request) as plain dicts, for JSON encoding."""
    if hasattr(x, "items"):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    return x


def _one_line(text: str) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= 200 else line[:197] + "..."
