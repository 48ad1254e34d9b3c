"""The process a local GGUF model runs in: ``python -m llmpas.reasoning.backends.llamacpp_worker
FD``, started by :class:`llmpas.reasoning.backends.llamacpp.LlamaCppBackend`.

llama.cpp is native code: a segmentation fault, an abort or an out-of-memory kill in it must
cost one request, not the caller's run. The worker speaks JSON messages over the socket ``FD``
(a :class:`multiprocessing.connection.Connection`), one request at a time:

- ``{"load": {...}}`` -> ``{"ready": seconds}`` or ``{"error": "..."}`` (the first message);
- ``{"id": N, "complete": {...}}`` -> ``{"id": N, "ok": {...}}`` or ``{"id": N, "error": "..."}``;
- ``{"id": N, "score": {"messages": [...], "prefix": "...", "choices": [...]}}`` -> ``{"id": N,
  "ok": {"logprobs": [[...], ...], "prompt_tokens": P}}``: each choice's token log-probabilities
  after the chat's prompt and the prefix (a request kind of its own: :func:`_score`).

It exits when the socket closes or its parent is gone, and ignores Ctrl-C (the parent decides).
Weights are not repacked into llama.cpp's extra buffer types unless asked (``extra_bufts``): the
AMX repacking path crashes on some CPUs with AMX (llama.cpp issue #20824).
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from multiprocessing.connection import Connection
from typing import Any

PARENT_POLL = 0.5  # seconds between checks that the parent is still there


def main(argv: list[str]) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    conn = Connection(int(argv[0]))
    _exit_with_parent(os.getppid())
    try:
        first = json.loads(conn.recv_bytes())
        try:
            llama = _load(**first["load"])
        except Exception as err:  # sent to the parent as one line
            conn.send_bytes(_dump({"error": _line(err)}))
            return 1
        conn.send_bytes(_dump({"ready": True}))
        while True:
            message = json.loads(conn.recv_bytes())
            answer = _score(llama, message) if "score" in message else _answer(llama, message)
            conn.send_bytes(_dump(answer))
    except (EOFError, OSError):  # the parent closed the socket: stop
        return 0


def _exit_with_parent(parent: int) -> None:
    """A daemon thread ending this process when its parent is gone (a killed parent never
    closes the socket while the worker is decoding)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _load(model_path: str, n_ctx: int, n_threads: int, seed: int, extra_bufts: bool) -> Any:
    import llama_cpp

    with _model_params(llama_cpp, extra_bufts):
        return llama_cpp.Llama(
            model_path=model_path, n_ctx=n_ctx, n_threads=n_threads, seed=seed, verbose=False
        )


@contextmanager
def _model_params(llama_cpp: Any, extra_bufts: bool) -> Iterator[None]:
    """``Llama`` (0.3.36) takes no ``use_extra_bufts``: while it is built here, its default
    model parameters get the one we want (this process holds nothing else)."""
    from llama_cpp import llama as llama_module

    native = llama_module.llama_cpp
    defaults = native.llama_model_default_params

    def params() -> Any:
        p = defaults()
        if hasattr(p, "use_extra_bufts"):
            p.use_extra_bufts = extra_bufts
        return p

    native.llama_model_default_params = params
    try:
        yield
    finally:
        native.llama_model_default_params = defaults


def _answer(llama: Any, message: dict[str, Any]) -> dict[str, Any]:
    ident = message.get("id")
    kwargs = dict(message["complete"])
    try:
        if kwargs.get("grammar") is not None:
            kwargs["grammar"] = _grammar(llama, kwargs["grammar"])
        out = llama.create_chat_completion(**kwargs)
    except Exception as err:  # one request failed; the worker goes on
        return {"id": ident, "error": _line(err)}
    usage = out.get("usage") or {}
    choice = out["choices"][0]
    return {
        "id": ident,
        "ok": {
            "text": choice["message"].get("content") or "",
            "prompt_tokens": usage.get("prompt_tokens", 0),
            "completion_tokens": usage.get("completion_tokens", 0),
            "finish_reason": choice.get("finish_reason"),
        },
    }


def _score(llama: Any, message: dict[str, Any]) -> dict[str, Any]:
    """The log-probability of every token of each choice, read from the model's logits after
    the chat prompt (the model's own chat template), the prefix and the choice's earlier tokens.

    Only what the model's cache does not already hold is evaluated: the prompt once (its part
    shared with earlier requests not even that), and of each choice the tokens after those it
    shares with the choice before (``(and (scanned`` is common to many; their log-probabilities,
    the same context and the same tokens, are taken from the choice before). A choice's own
    tokens are decoded one at a time: on a CPU without fast batched kernels a small batch costs
    far more than its tokens one by one. Scores can differ in the last digits with what the
    cache held (batching changes the arithmetic): recorded scores replay exactly."""
    ident = message.get("id")
    ask = message["score"]
    try:
        prompt = _chat_prompt(llama, ask["messages"]) + str(ask.get("prefix", ""))
        base = _tokens(llama, prompt)
        known: dict[int, float] = {}  # position -> log p(token there | the cached tokens before)
        out = []
        for choice in ask["choices"]:
            tokens = _tokens(llama, prompt + str(choice))
            start = _shared(base, tokens)
            if start < 1 or start >= len(tokens):
                raise ValueError(f"choice {choice!r} adds no token to the prompt")
            out.append(_logprobs(llama, tokens, start, known))
    except Exception as err:  # one request failed; the worker goes on
        return {"id": ident, "error": _line(err)}
    return {"id": ident, "ok": {"logprobs": out, "prompt_tokens": len(base)}}


def _logprobs(llama: Any, tokens: list[int], start: int, known: dict[int, float]) -> list[float]:
    """log p(tokens[i] | tokens[:i]) for i >= start: those at positions the cache holds with
    the same tokens from ``known``, the rest decoded one token at a time."""
    import llama_cpp
    import numpy as np

    cached = [int(t) for t in llama.input_ids[: llama.n_tokens]]
    shared = _shared(cached, tokens)
    reuse = start
    while reuse < min(shared, len(tokens) - 1) and reuse in known:
        reuse += 1  # tokens[start:reuse] are scored already, in this very context
    keep = min(shared, reuse - 1)
    for i in [k for k in known if k >= keep + 1 and k >= reuse]:
        del known[i]
    llama.n_tokens = keep
    if keep < reuse - 1:
        llama.eval(tokens[keep : reuse - 1])  # the prompt (or its part not cached): a batch
    llama.eval(tokens[reuse - 1 : reuse])
    n_vocab = llama.n_vocab()
    out = [known[i] for i in range(start, reuse)]
    for i in range(reuse, len(tokens)):
        raw = llama_cpp.llama_get_logits_ith(llama.ctx, -1)
        logits = np.ctypeslib.as_array(raw, shape=(n_vocab,)).astype(np.float64)
        top = logits.max()
        known[i] = float(logits[tokens[i]] - (top + np.log(np.exp(logits - top).sum())))
        out.append(known[i])
        if i + 1 < len(tokens):
            llama.eval(tokens[i : i + 1])
    return out


def _chat_prompt(llama: Any, messages: list[dict[str, str]]) -> str:
    """The chat as the model's template writes it, ready for the assistant's answer (ChatML
    when the model has no template)."""
    template = (getattr(llama, "metadata", None) or {}).get("tokenizer.chat_template")
    if template:
        from llama_cpp import llama_chat_format

        def text(token: int) -> str:
            return str(llama._model.token_get_text(token)) if token != -1 else ""

        formatter = llama_chat_format.Jinja2ChatFormatter(
            template=template,
            eos_token=text(llama.token_eos()),
            bos_token=text(llama.token_bos()),
            add_generation_prompt=True,
        )
        return str(formatter(messages=messages).prompt)  # type: ignore[arg-type]
    chat = "".join(f"<|im_start|>{m['role']}\n{m['content']}<|im_end|>\n" for m in messages)
    return chat + "<|im_start|>assistant\n"


def _tokens(llama: Any, text: str) -> list[int]:
    return list(llama.tokenize(text.encode("utf-8"), add_bos=True, special=True))


def _shared(a: list[int], b: list[int]) -> int:
    n = 0
    while n < min(len(a), len(b)) and a[n] == b[n]:
        n += 1
    return n


def _grammar(llama: Any, text: str) -> Any:
    """The grammar, parsed by llama.cpp's own GBNF parser first: ``LlamaGrammar.from_string``
    only stores the string, and a grammar llama.cpp cannot parse gives a NULL sampler that
    crashes the process at the first sampled token."""
    import llama_cpp

    vocab = llama_cpp.llama_model_get_vocab(llama.model)
    sampler = llama_cpp.llama_sampler_init_grammar(vocab, text.encode("utf-8"), b"root")
    if not sampler:
        shown = " ".join(text.split())[:80]
        raise ValueError(f"invalid GBNF grammar (llama.cpp cannot parse {shown!r})")
    llama_cpp.llama_sampler_free(sampler)
    return llama_cpp.LlamaGrammar.from_string(text, verbose=False)


def _line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__


def _dump(data: dict[str, Any]) -> bytes:
    return json.dumps(data).encode("ascii")  # lone surrogates travel as \\u escapes


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
