"""The process a local GGUF model runs in: ``python -m llmpas.reasoning.backends.llamacpp_worker
FD``, started by :class:`llmpas.reasoning.backends.llamacpp.LlamaCppBackend`.

llama.cpp is native code: a segmentation fault, an abort or an out-of-memory kill in it must
cost one request, not the caller's run. The worker speaks JSON messages over the socket ``FD``
(a :class:`multiprocessing.connection.Connection`), one request at a time:

- ``{"load": {...}}`` -> ``{"ready": seconds}`` or ``{"error": "..."}`` (the first message);
- ``{"id": N, "complete": {...}}`` -> ``{"id": N, "ok": {...}}`` or ``{"id": N, "error": "..."}``.

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
            conn.send_bytes(_dump(_answer(llama, message)))
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
