"""An OpenAI-compatible chat-completions backend that treats the server as untrusted.

The request goes through the ``openai`` SDK, but every limit is ours: the SDK's retries are off
(ours retry only timeouts, connection errors, 5xx and 429) and it sends through a
:class:`~llmpas.reasoning.backends.bounded_http.BoundedTransport`, which gives each attempt one
deadline (connecting, sending, headers and body included, enforced by a watchdog that shuts the
socket) and bounds the answer's size, error bodies included. The SDK never parses the answer: its
raw JSON is checked strictly here. Whatever the server does (non-JSON, invalid UTF-8,
``{"choices": "nope"}``, 500s, a 401 echoing the ``Authorization`` header, a body that never
ends), :meth:`OpenAIBackend.complete` returns a :class:`Response` or raises an
:class:`LLMServerError` with one line naming the server (``host:port`` and the model); the API
key is redacted from every text that leaves this module (answers and error bodies included).

**Scores** (:meth:`OpenAIBackend.score`, what ``flp-choose`` ranks by): for each choice one chat
request whose answer a GBNF grammar fixes to the prefix and the choice (``grammar``, which
``llama_cpp.server`` reads from the body), with ``logprobs``: the server evaluates the shared
prompt once and keeps it (its own prefix reuse), each choice costs its own tokens, and the
answer's token log-probabilities are the model's (the grammar only picks the token; llama.cpp
reports the log-probability before it). The tokens wholly inside the prefix are left out, as the
in-process scorer does. A server that does not honour the grammar (its answer is not the choice),
returns no log-probabilities, or refuses the request (HTTP 4xx) cannot score:
:class:`ScoringUnsupported` (the caller asks for a numbered choice) and it is not asked again.
(The completions endpoint's ``echo`` would score the prompt's own tokens, but llama-cpp-python
0.3 misaligns them for a model without a BOS token, as Qwen2.5 and SmolLM2 are.)
"""

from __future__ import annotations

import json
import logging
import os
import time
import urllib.parse
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from llmpas.reasoning.grammar import literal as gbnf_literal
from llmpas.reasoning.llm import (
    Fault,
    LLMError,
    LLMServerError,
    Request,
    Response,
    ScoreRequest,
    Scores,
    ScoringUnsupported,
)
from llmpas.safetext import one_line, redact

log = logging.getLogger(__name__)

LOCAL_DUMMY_KEY = "sk-local-no-key"  # local servers (llama.cpp, vLLM) accept any key
DEFAULT_BASE_URL = "https://api.openai.com/v1"
MAX_BYTES = 1 << 20  # an answer of max_tokens tokens is a few kB; 1 MiB is far beyond
RETRYABLE = (Fault.TIMEOUT, Fault.CONNECTION)
INSTALL_HINT = "pip install 'llmpas[llm]' (or pip install 'openai>=3,<4')"


@dataclass(frozen=True)
class Endpoint:
    """Where the server is: ``scheme://host:port/path`` (user info and query never kept)."""

    scheme: str
    host: str
    port: int
    path: str

    def __post_init__(self) -> None:
        if self.scheme not in ("http", "https"):
            raise ValueError(f"LLM server URL must be http:// or https://, got {self.scheme!r}")
        if not self.host:
            raise ValueError("LLM server URL has no host")

    @classmethod
    def parse(cls, url: str) -> Endpoint:
        parts = urllib.parse.urlsplit(url.strip())
        try:
            port = parts.port
        except ValueError:
            raise ValueError(f"LLM server URL has a bad port: {redact(url)!r}") from None
        scheme = parts.scheme.lower()
        default = 443 if scheme == "https" else 80
        return cls(scheme, parts.hostname or "", port or default, parts.path.rstrip("/"))

    @property
    def hostport(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{host}:{self.port}"

    @property
    def url(self) -> str:
        return f"{self.scheme}://{self.hostport}{self.path}"


class OpenAIBackend:
    """Chat completions over HTTP from any OpenAI-compatible server.

    ``timeout`` bounds each attempt as a whole; timeouts, connection errors, HTTP 5xx and 429
    are retried ``max_retries`` times with exponential backoff (``backoff``, ``2*backoff``,
    ...). ``max_bytes`` bounds the answer's size. The API key is sent in the ``Authorization``
    header and redacted from everything else.
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
        max_bytes: int = MAX_BYTES,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not timeout > 0:
            raise ValueError(f"timeout must be > 0, got {timeout}")
        if max_retries < 0:
            raise ValueError(f"max_retries must be >= 0, got {max_retries}")
        if max_bytes < 1:
            raise ValueError(f"max_bytes must be >= 1, got {max_bytes}")
        url = base_url or os.environ.get("OPENAI_BASE_URL") or None
        self.model = model
        self.name = f"openai:{model}"
        self.timeout = timeout
        self.max_retries = max_retries
        self.backoff = backoff
        self.max_bytes = max_bytes
        self._sleep = sleep
        self._key = _resolve_key(api_key, url)
        self.endpoint = Endpoint.parse(url or DEFAULT_BASE_URL)
        self.base_url = self.endpoint.url
        self.server = f"{self.name} at {self.endpoint.hostport}"
        self._client = _sdk_client(self.base_url, self._key, timeout, max_bytes)
        self._cannot_score = ""  # why this server cannot score ("": not known to fail)
        self._no_tokenizer = False  # the server has no /extras/tokenize (llama_cpp.server's)

    def __repr__(self) -> str:  # no key in here, ever
        return f"OpenAIBackend(model={self.model!r}, base_url={self.base_url!r})"

    def redact(self, text: str) -> str:
        return redact(text, (self._key,))

    def complete(self, request: Request) -> Response:
        attempts = self.max_retries + 1
        for attempt in range(1, attempts + 1):
            try:
                return self._attempt(request)
            except LLMServerError as err:
                retry = err.fault in RETRYABLE or (err.status or 0) >= 500 or err.status == 429
                if not retry:
                    raise
                log.warning(
                    "%s: attempt %d/%d failed: %s", self.server, attempt, attempts, err.reason
                )
                if attempt == attempts:
                    reason = f"{err.reason} ({attempts} attempt{'s' if attempts > 1 else ''})"
                    raise LLMServerError(self.server, err.fault, reason, err.status) from None
                self._sleep(self.backoff * 2 ** (attempt - 1))
        raise AssertionError("unreachable")  # pragma: no cover

    def score(self, request: ScoreRequest) -> Scores:
        """Each choice's token log-probabilities after the chat and ``request.prefix`` (see the
        module's doc); :class:`ScoringUnsupported` when this server cannot give them."""
        if self._cannot_score:
            raise ScoringUnsupported(f"{self.server}: {self._cannot_score}")
        logprobs: list[tuple[float, ...]] = []
        prompt_tokens = 0
        start = time.perf_counter()
        budget = self.timeout * SCORE_BUDGET
        for choice in request.choices:
            if time.perf_counter() - start > budget:
                why = f"scoring {len(request.choices)} choices took over {budget:g} s"
                raise self._fail(Fault.TIMEOUT, why)
            try:
                lp, prompt_tokens = self._score_one(request, choice)
            except _NoScores as err:
                self._cannot_score = str(err)
                raise ScoringUnsupported(f"{self.server}: {err}") from None
            logprobs.append(lp)
        return Scores(tuple(logprobs), self.name, prompt_tokens, time.perf_counter() - start)

    def _score_one(self, request: ScoreRequest, choice: str) -> tuple[tuple[float, ...], int]:
        text = request.prefix + choice
        tokens = self._canonical(request.prefix, text)
        if tokens is not None:  # the model's own tokens of the text, forced one by one
            forced_tokens, skip = tokens
            grammar = "root ::= " + " ".join(f"<[{t}]>" for t in forced_tokens) + "\n"
            bound = len(forced_tokens) + 1
        else:  # the text, tokens as the sampler picks them
            grammar, skip, bound = f"root ::= {gbnf_literal(text)}\n", -1, len(text.encode()) + 4
        forced = Request(
            request.messages,
            temperature=0.0,
            max_tokens=min(bound, MAX_SCORED_TOKENS),
            grammar=grammar,
        )
        body = {**self.create_kwargs(forced), "logprobs": True, "top_logprobs": 1}
        try:
            data, _ = self._post(body)
        except LLMServerError as err:
            if err.status is not None and 400 <= err.status < 500 and err.status != 429:
                raise _NoScores(f"the server refused a scoring request ({err.reason})") from None
            raise
        completion = self._json(data)
        try:
            if skip >= 0:
                return _token_logprobs(completion, text, skip, len(forced_tokens))
            return _choice_logprobs(completion, text, len(request.prefix))
        except _Shape as err:
            raise self._fail(Fault.MALFORMED, f"not a scored chat completion: {err}") from None

    def _canonical(self, prefix: str, text: str) -> tuple[list[int], int] | None:
        """``text``'s tokens as the model's tokenizer writes them (``llama_cpp.server``'s
        ``/extras/tokenize``; a BOS it adds left out) and how many of them ``prefix`` alone
        shares; None where the server has no tokenizer endpoint (then the grammar forces the
        text and the sampler picks its tokens, which may be another segmentation)."""
        if self._no_tokenizer:
            return None
        try:
            empty, head, full = (self._tokenize(t) for t in ("", prefix, text))
        except (LLMServerError, _Shape):
            self._no_tokenizer = True
            return None
        bos = len(empty) if empty == full[: len(empty)] else 0
        full, head = full[bos:], head[bos:]
        shared = 0
        while shared < min(len(head), len(full) - 1) and head[shared] == full[shared]:
            shared += 1
        return (full, shared) if full and len(full) <= MAX_SCORED_TOKENS else None

    def _tokenize(self, text: str) -> list[int]:
        import httpx2
        import openai

        url = f"{self.endpoint.scheme}://{self.endpoint.hostport}/extras/tokenize"
        body = json.dumps({"model": self.model, "input": text}).encode()
        try:
            answer = self._client.post(url, cast_to=httpx2.Response, content=body)
        except openai.APIStatusError as err:
            raise self._fail(Fault.HTTP, f"HTTP {err.status_code}", err.status_code) from None
        except openai.APIConnectionError as err:
            raise self._transport_failure(err) from None
        tokens = _field(self._json(answer.content), "tokens", list, "tokenize")
        if not all(
            isinstance(t, int) and not isinstance(t, bool) and 0 <= t < 1 << 31 for t in tokens
        ):
            raise _Shape("tokenize.tokens are not token ids")
        return tokens

    def _post(self, body: dict[str, Any]) -> tuple[bytes, float]:
        """One POST of ``body`` to ``/chat/completions`` (retried as :meth:`complete` is): the
        answer's raw bytes and the seconds it took."""
        attempts = self.max_retries + 1
        for attempt in range(1, attempts + 1):
            try:
                return self._send(body)
            except LLMServerError as err:
                retry = err.fault in RETRYABLE or (err.status or 0) >= 500 or err.status == 429
                if not retry or attempt == attempts:
                    raise
                self._sleep(self.backoff * 2 ** (attempt - 1))
        raise AssertionError("unreachable")  # pragma: no cover

    def _send(self, kwargs: dict[str, Any]) -> tuple[bytes, float]:
        import httpx2
        import openai

        body = json.dumps(kwargs).encode()
        start = time.perf_counter()
        try:
            answer = self._client.post("/chat/completions", cast_to=httpx2.Response, content=body)
        except openai.APIStatusError as err:
            why = f"HTTP {err.status_code}{_error_detail(err.response.content)}"
            raise self._fail(Fault.HTTP, why, err.status_code) from None
        except openai.APIConnectionError as err:
            raise self._transport_failure(err) from None
        return answer.content, time.perf_counter() - start

    def _json(self, data: bytes) -> Any:
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as err:
            raise self._fail(Fault.MALFORMED, f"answer is not UTF-8 (byte {err.start})") from None
        try:
            return json.loads(text)
        except (ValueError, RecursionError) as err:
            why = getattr(err, "msg", None) or type(err).__name__
            raise self._fail(Fault.MALFORMED, f"answer is not JSON ({why})") from None

    def _fail(self, fault: Fault, reason: str, status: int | None = None) -> LLMServerError:
        return LLMServerError(self.server, fault, one_line(self.redact(reason)), status)

    def _attempt(self, request: Request) -> Response:
        data, seconds = self._send(self.create_kwargs(request))  # ASCII: surrogates escaped
        return self._response(data, seconds)

    def _transport_failure(self, err: Exception) -> LLMServerError:
        from httpx2 import TimeoutException

        from llmpas.reasoning.backends.bounded_http import BodyTooLarge

        cause = err.__cause__
        if isinstance(cause, BodyTooLarge):
            return self._fail(Fault.TOO_LARGE, f"answer larger than {self.max_bytes} bytes")
        if isinstance(cause, TimeoutException):
            return self._fail(Fault.TIMEOUT, f"timed out after {self.timeout:g} s")
        why = f"{type(cause).__name__}: {cause}" if cause is not None else str(err)
        return self._fail(Fault.CONNECTION, f"connection failed: {why}")

    def _response(self, data: bytes, latency: float) -> Response:
        completion = self._json(data)  # ValueError caught there: also 5000-digit numbers
        try:
            return _to_response(completion, self.model, latency, self.redact)
        except _Shape as err:
            raise self._fail(Fault.MALFORMED, f"not a chat completion: {err}") from None

    def create_kwargs(self, request: Request) -> dict[str, Any]:
        """The JSON body of the chat-completions request for ``request``."""
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
            kwargs["grammar"] = request.grammar  # llama.cpp's server reads it from the body
        return kwargs


def _sdk_client(base_url: str, key: str, timeout: float, max_bytes: int) -> Any:
    """The ``openai`` client: no retries of its own, every request through a bounded transport."""
    try:
        import httpx2
        import openai

        from llmpas.reasoning.backends.bounded_http import BoundedTransport
    except ImportError:
        raise LLMError(f"the openai package (3.x) is not installed: {INSTALL_HINT}") from None
    waits = httpx2.Timeout(timeout)  # connect, write, each read: within the attempt's deadline
    http = httpx2.Client(transport=BoundedTransport(timeout, max_bytes), timeout=waits)
    return openai.OpenAI(
        base_url=base_url, api_key=key, max_retries=0, timeout=waits, http_client=http
    )


def _resolve_key(api_key: str | None, base_url: str | None) -> str:
    key = api_key or os.environ.get("OPENAI_API_KEY")
    if key:
        if any(c in key for c in "\r\n\0"):
            raise LLMError("the API key contains a line break or NUL")
        return key
    if base_url is not None:
        return LOCAL_DUMMY_KEY
    raise LLMError("no OpenAI API key: set OPENAI_API_KEY or pass base_url for a local server")


class _Shape(ValueError):
    """The answer is JSON but not a chat completion."""


class _NoScores(ValueError):
    """The server answered but cannot score (no log-probabilities, the grammar ignored)."""


SCORE_BUDGET = 4  # one score request's choices together: at most this many request timeouts
MAX_SCORED_TOKENS = 512  # the tokens of one scored choice, at most (a goal set is ~10-60)


def _token_logprobs(
    completion: Any, text: str, skip: int, count: int
) -> tuple[tuple[float, ...], int]:
    """The log-probabilities of the answer's tokens after its first ``skip`` (the prefix's),
    when the answer is ``text`` in ``count`` tokens (each forced by the grammar)."""
    choices = _field(completion, "choices", list, "answer")
    if not choices:
        raise _Shape("answer.choices is empty")
    message = _field(choices[0], "message", dict, "answer.choices[0]")
    if message.get("content") != text:
        raise _NoScores("its answer is not the choice it was asked to score (grammar ignored?)")
    logprobs = choices[0].get("logprobs")
    content = logprobs.get("content") if isinstance(logprobs, dict) else None
    if not isinstance(content, list) or len(content) < count:
        raise _NoScores("it returns no log-probability for each token of the choice")
    out = [_logprob(item, i) for i, item in enumerate(content[:count])]
    return tuple(out[skip:]), _tokens(completion.get("usage"), "prompt_tokens")


def _logprob(item: Any, i: int) -> float:
    where = f"answer.choices[0].logprobs.content[{i}]"
    if not isinstance(item, dict):
        raise _Shape(f"{where} is not an object")
    value: Any = item.get("logprob")
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if not ok or not -1e6 < float(value) <= 1e-3:  # float32 rounding: a hair above 0
        raise _Shape(f"{where}.logprob is {_kind(value)}")
    return float(value)


def _choice_logprobs(completion: Any, text: str, skip: int) -> tuple[tuple[float, ...], int]:
    """The log-probabilities of the answer's tokens that end after its first ``skip``
    characters (the prefix), checking that the answer is ``text``; and the prompt's tokens.
    :class:`_NoScores` when the server answered otherwise (no log-probabilities, another text)."""
    choices = _field(completion, "choices", list, "answer")
    if not choices:
        raise _Shape("answer.choices is empty")
    message = _field(choices[0], "message", dict, "answer.choices[0]")
    if message.get("content") != text:
        raise _NoScores("its answer is not the choice it was asked to score (grammar ignored?)")
    logprobs = choices[0].get("logprobs")
    content = logprobs.get("content") if isinstance(logprobs, dict) else None
    if not isinstance(content, list) or not content:
        raise _NoScores("it returns no token log-probabilities")
    out: list[float] = []
    end = 0
    for i, item in enumerate(content[: MAX_SCORED_TOKENS + 8]):
        token = _field(item, "token", str, f"answer.choices[0].logprobs.content[{i}]")
        value = item.get("logprob")
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        if not ok or not -1e6 < float(value) <= 1e-3:  # float32 rounding: a hair above 0
            raise _Shape(f"answer.choices[0].logprobs.content[{i}].logprob is {_kind(value)}")
        start, end = end, end + len(token)
        if end > skip and start < len(text):
            out.append(float(value))
    spelled = "".join(str(item.get("token")) for item in content[: MAX_SCORED_TOKENS + 8])
    if not spelled.startswith(text) or not out:
        raise _NoScores("its log-probabilities' tokens do not spell the choice")
    usage = completion.get("usage")
    return tuple(out), _tokens(usage, "prompt_tokens")


def _field(obj: Any, key: str, kind: type, where: str) -> Any:
    if not isinstance(obj, dict):
        raise _Shape(f"{where} is not an object")
    value = obj.get(key)
    if not isinstance(value, kind):
        raise _Shape(f"{where}.{key} is {_kind(value)}")
    return value


def _kind(value: Any) -> str:
    return "missing" if value is None else f"a {type(value).__name__}"


def _tokens(usage: Any, key: str) -> int:
    value = usage.get(key, 0) if isinstance(usage, dict) else 0
    ok = isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 1 << 31
    return value if ok else 0


def _to_response(
    completion: Any, model: str, latency: float, clean: Callable[[str], str]
) -> Response:
    choices = _field(completion, "choices", list, "answer")
    if not choices:
        raise _Shape("answer.choices is empty")
    message = _field(choices[0], "message", dict, "answer.choices[0]")
    content = message.get("content")
    if content is not None and not isinstance(content, str):
        raise _Shape(f"answer.choices[0].message.content is {_kind(content)}")
    name = completion.get("model")
    reason = choices[0].get("finish_reason")
    usage = completion.get("usage")
    return Response(
        text=clean(content or ""),
        model=clean(name)[:200] if isinstance(name, str) and name else model,
        prompt_tokens=_tokens(usage, "prompt_tokens"),
        completion_tokens=_tokens(usage, "completion_tokens"),
        latency=latency,
        meta={"finish_reason": clean(reason)[:50] if isinstance(reason, str) else None},
    )


def _error_detail(data: bytes) -> str:
    """``": <message>"`` from an error body (OpenAI's ``{"error": {"message": ...}}`` or the
    text itself), for the one-line error; the caller redacts and shortens it."""
    text = data[:4096].decode("utf-8", "replace")
    try:
        body = json.loads(text)
    except (ValueError, RecursionError):
        body = None
    if isinstance(body, dict):
        err = body.get("error")
        msg = err.get("message") if isinstance(err, dict) else err
        if isinstance(msg, str):
            text = msg
    return f": {text}" if text.strip() else ""


def _plain(x: Any) -> Any:
    """Mappings (e.g. the read-only schema of a request) as plain dicts, for JSON encoding."""
    if isinstance(x, Mapping):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    return x
