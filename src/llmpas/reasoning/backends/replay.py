"""Record/replay cassettes: one JSON file per request, named ``<Request.key()>.json``."""

from __future__ import annotations

import json
import logging
import os
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal, get_args

from llmpas.files import atomic_write
from llmpas.reasoning.llm import (
    LLM,
    LLMError,
    Request,
    Response,
    ScoreRequest,
    Scores,
    ScoringUnsupported,
)

log = logging.getLogger(__name__)

ReplayMode = Literal["replay", "record", "auto"]
CASSETTE_VERSION = 1


class ReplayBackend:
    """Answers from recorded cassettes; records them from ``inner`` when asked.

    ``replay``: only cassettes, a missing one is an :class:`LLMError`; ``record``: always ask
    ``inner`` and (over)write the cassette; ``auto``: replay when recorded, otherwise record.

    Latency is counted once. ``replay``: a cassette's recorded latency (what the recorded run
    waited), the first time this backend serves it; ``auto``: only what this run waited for
    ``inner`` (a cassette served, recorded earlier or earlier in this run, took no model time).
    Any other serving has latency 0 and the recorded one in ``meta["recorded_latency"]``.
    """

    def __init__(
        self, folder: str | os.PathLike[str], inner: LLM | None = None, mode: ReplayMode = "replay"
    ) -> None:
        if mode not in get_args(ReplayMode):
            raise ValueError(f"mode must be one of {get_args(ReplayMode)}, got {mode!r}")
        if mode == "record" and inner is None:
            raise ValueError("record mode needs an inner LLM to record from")
        self.folder = Path(folder)
        self.inner = inner
        self.mode: ReplayMode = mode
        self.name = f"replay({inner.name})" if inner is not None else "replay"
        self._counted: set[str] = set()  # keys whose latency was counted

    def path_for(self, request: Request) -> Path:
        return self.folder / f"{request.key()}.json"

    def complete(self, request: Request) -> Response:
        path = self.path_for(request)
        key = path.stem
        if self.mode != "record" and path.is_file():
            response = self._load(path)
            if self.mode == "replay" and key not in self._counted:
                self._counted.add(key)
                return response
            meta = {**response.meta, "recorded_latency": response.latency}
            return replace(response, latency=0.0, meta=meta)
        if self.mode == "replay" or self.inner is None:
            raise self._missing(request)
        response = self.inner.complete(request)
        self._save(path, request, response)
        self._counted.add(key)
        return response

    def score(self, request: ScoreRequest) -> Scores:
        """Recorded scores (a cassette of kind ``score``); recorded from ``inner`` when it can
        score. ``ScoringUnsupported`` when there is no recording to replay and nothing that can
        score: the caller then asks for a numbered choice, which replays or records as any
        request."""
        path = self.folder / f"{request.key()}.json"
        if self.mode != "record" and path.is_file():
            return self._load_scores(path)
        scorer = getattr(self.inner, "score", None)
        if self.mode == "replay" or not callable(scorer):
            raise ScoringUnsupported(f"no recorded scores for {request.tag or 'request'}")
        scores: Scores = scorer(request)
        text = json.dumps(_score_cassette(request, scores), indent=2, ensure_ascii=False)
        _atomic_write(path, text + "\n")
        log.info("recorded %s (scores, %s)", path.name, request.tag or "untagged")
        return scores

    def _load_scores(self, path: Path) -> Scores:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            got = data["scores"]
            return Scores(
                tuple(tuple(float(x) for x in lp) for lp in got["logprobs"]),
                model=str(got.get("model", "")),
                prompt_tokens=int(got.get("prompt_tokens", 0)),
                latency=float(got.get("latency", 0.0)),
            )
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise LLMError(f"unreadable cassette {path}: {type(err).__name__}: {err}") from None

    def _missing(self, request: Request) -> LLMError:
        tag = request.tag or "request"
        return LLMError(
            f"no recorded response for {tag} (key {request.key()[:12]}...) in {self.folder}; "
            "record it with --record"
        )

    def _load(self, path: Path) -> Response:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            resp = data["response"]
            response = Response(
                text=resp["text"],
                model=resp.get("model", ""),
                prompt_tokens=resp.get("prompt_tokens", 0),
                completion_tokens=resp.get("completion_tokens", 0),
                latency=resp.get("latency", 0.0),
                meta={**resp.get("meta", {}), "replayed": True},
            )
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise LLMError(f"unreadable cassette {path}: {type(err).__name__}: {err}") from None
        log.debug("replayed %s", path.name)
        return response

    def _save(self, path: Path, request: Request, response: Response) -> None:
        text = json.dumps(_cassette(request, response), indent=2, ensure_ascii=False) + "\n"
        _atomic_write(path, text)
        log.info("recorded %s (%s)", path.name, request.tag or "untagged")


def _cassette(request: Request, response: Response) -> dict[str, Any]:
    return {
        "version": CASSETTE_VERSION,
        "key": request.key(),
        "tag": request.tag,
        "request": {
            "messages": [{"role": m.role, "content": m.content} for m in request.messages],
            "temperature": request.temperature,
            "max_tokens": request.max_tokens,
            "seed": request.seed,
            "grammar": request.grammar,
            "json_schema": _plain(request.json_schema),
        },
        "response": {
            "text": response.text,
            "model": response.model,
            "prompt_tokens": response.prompt_tokens,
            "completion_tokens": response.completion_tokens,
            "latency": response.latency,
            "meta": _plain(response.meta),
        },
    }


def _score_cassette(request: ScoreRequest, scores: Scores) -> dict[str, Any]:
    return {
        "version": CASSETTE_VERSION,
        "kind": "score",
        "key": request.key(),
        "tag": request.tag,
        "request": {
            "messages": [{"role": m.role, "content": m.content} for m in request.messages],
            "prefix": request.prefix,
            "choices": list(request.choices),
        },
        "scores": {
            "logprobs": [list(lp) for lp in scores.logprobs],
            "model": scores.model,
            "prompt_tokens": scores.prompt_tokens,
            "latency": scores.latency,
        },
    }


def _atomic_write(path: Path, text: str) -> None:
    atomic_write(path, text)


def _plain(x: Any) -> Any:
    if hasattr(x, "items"):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    return x
