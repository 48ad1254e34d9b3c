"""The process a local GGUF model runs in: ``python -m llmpas.reasoning.backends.llamacpp_worker
FD``, started by :class:`llmpas.reasoning.backends.llamacpp.LlamaCppBackend`.

llama.cpp is native code: a segmentation fault, an abort or an out-of-memory kill in it must
cost one request, not the caller's run. The worker speaks JSON messages over the socket ``FD``
(a :class:`multiprocessing.connection.Connection`), one request at a time:

- ``{"load": {...}}`` -> ``{"ready": seconds}`` or ``{"error": "..."}`` (the first message);
- ``{"id": N, KIND: {...}}`` -> ``{"id": N, "ok": {...}}`` or ``{"id": N, "error": "..."}``, one
  request of a kind in :data:`REQUESTS` (``complete``: a chat completion; ``score``: each
  choice's token log-probabilities after the chat's prompt and a prefix, :func:`_score`).

KV states (``kv_states`` > 0): after each answer the worker keeps llama.cpp's KV state of the
tokens it evaluated (at most ``kv_states`` of them, the least recently used dropped); a request
starts from an empty context into which the kept state sharing the longest prefix with its
prompt is restored, cut to that prefix, so a prefix evaluated once (the system prompt and what
a world and a method fix, the conversation of a consultation: its goals prompt and answer under
the repair) is not evaluated again, whichever request came between. An answer is then the one a
fresh evaluation of its prompt gives, whatever came before (llama-cpp-python's own reuse, in
place, is not: see ``forget``). Each answer says how many prompt tokens were evaluated and how
many reused, and the seconds of each phase.

It exits when the socket closes or its parent is gone, and ignores Ctrl-C (the parent decides).
Weights are not repacked into llama.cpp's extra buffer types unless asked (``extra_bufts``): the
AMX repacking path crashes on some CPUs with AMX (llama.cpp issue #20824).
"""

from __future__ import annotations

import ctypes
import json
import os
import signal
import sys
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection
from types import MappingProxyType
from typing import Any

PARENT_POLL = 0.5  # seconds between checks that the parent is still there
#: Prompt tokens always evaluated after a kept state: llama.cpp evaluates a few tokens with
#: other kernels than a batch, and the logits differ in their last bits (measured: the last 1,
#: 2, 3 or 4 tokens of a prompt evaluated after the rest gave other logits than the prompt in
#: one batch, and another greedy answer; 8 and 16 gave the same logits, bit for bit, with the
#: offline model, 2 to 64 with SmolLM2)
TAIL = 8


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
            answer = _answer(llama, message)
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


def _load(
    model_path: str,
    n_ctx: int,
    n_threads: int,
    seed: int,
    extra_bufts: bool,
    kv_states: int = 0,
) -> Any:
    import llama_cpp

    with _model_params(llama_cpp, extra_bufts):
        llama = _model_class()(
            model_path=model_path,
            n_ctx=n_ctx,
            n_threads=n_threads,
            n_threads_batch=n_threads,
            seed=seed,
            verbose=False,
        )
    if kv_states > 0:
        llama.set_cache(KVStates(kv_states))
    return llama


@dataclass(frozen=True)
class KVState:
    """llama.cpp's KV state of sequence 0 after evaluating ``input_ids`` (``Llama.save_state``
    keeps the logits too: 311 MB for this model, where these bytes are ~28 kB a token)."""

    input_ids: Any  # numpy array of the tokens evaluated (``Llama`` reads ``.input_ids``)
    data: bytes
    saved: int = -1  # tokens ``data`` holds when more than ``input_ids`` (-1: as many)


class KVStates:
    """At most ``capacity`` :class:`KVState`, keyed by their tokens; ``states[prompt]`` is the
    one sharing the longest prefix with ``prompt`` (KeyError: none shares a token). It is what
    ``Llama`` calls its cache (``Llama.set_cache``): it looks the prompt up before an answer and
    stores the state after it."""

    def __init__(self, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.capacity = capacity
        self.states: OrderedDict[tuple[int, ...], KVState] = OrderedDict()

    def __bool__(self) -> bool:  # ``Llama`` tests ``if self.cache``: an empty one still is
        return True

    def __contains__(self, tokens: Sequence[int]) -> bool:
        return tuple(tokens) in self.states

    def __getitem__(self, tokens: Sequence[int]) -> KVState:
        """The kept state sharing the longest prefix with ``tokens``, cut to that prefix but
        the last :data:`TAIL` tokens of ``tokens``, which are evaluated (for the logits)."""
        wanted = list(tokens)
        best, length = None, 0
        for key in self.states:
            n = common_prefix(key, wanted)
            if n > length or (n == length and best is not None):  # ties: the latest
                best, length = key, n
        length = min(length, len(wanted) - TAIL)
        if best is None or length <= 0:
            raise KeyError("no kept state shares a prefix")
        self.states.move_to_end(best)
        found = self.states[best]
        return KVState(found.input_ids[:length], found.data, len(found.input_ids))

    def __setitem__(self, tokens: Sequence[int], state: KVState) -> None:
        key = tuple(int(t) for t in state.input_ids)  # what was evaluated, not what was asked
        self.states.pop(key, None)
        self.states[key] = state
        while len(self.states) > self.capacity:
            self.states.popitem(last=False)


def common_prefix(a: Sequence[int], b: Sequence[int]) -> int:
    """How many leading tokens ``a`` and ``b`` share."""
    n = 0
    for x, y in zip(a, b, strict=False):
        if x != y:
            break
        n += 1
    return n


def _model_class() -> Any:
    """``llama_cpp.Llama`` keeping KV states of sequence 0 only (no logits) and counting what
    it evaluates: the first ``eval`` of an answer is its prompt (the tokens not reused)."""
    import llama_cpp
    import numpy as np

    class Model(llama_cpp.Llama):
        meter: Meter | None = None

        def save_state(self) -> KVState:  # type: ignore[override]
            return KVState(np.array(self.input_ids[: self.n_tokens]), self._seq_data())

        def load_state(self, state: KVState) -> None:  # type: ignore[override]
            """The KV cells of ``state.input_ids`` restored as a fresh evaluation lays them
            out (cells 0..n-1, the next token in cell n): a state holding more is restored,
            cut and restored again, since the layout of the cells changes the sums of the
            attention in their last bits, and with them a greedy answer."""
            ctx = self._ctx.ctx
            memory = llama_cpp.llama_get_memory(ctx)
            n = len(state.input_ids)
            data = state.data
            if state.saved > n:
                data = self._cut(data, n)
            llama_cpp.llama_memory_clear(memory, True)
            self.n_tokens = 0
            if not data or not self._restore(data):
                llama_cpp.llama_memory_clear(memory, True)
                return  # nothing restored: the prompt is evaluated in full
            self.input_ids[:n] = state.input_ids
            self.n_tokens = n
            self._requires_eval = True

        def forget(self) -> None:
            """An empty context. llama-cpp-python reuses in place the prefix the last answer
            shares with the next prompt; a greedy answer then differs from a fresh evaluation
            of its prompt in places (measured: the same prompt asked twice in a row, its last
            token evaluated again on its own after the answer's cells were removed)."""
            llama_cpp.llama_memory_clear(llama_cpp.llama_get_memory(self._ctx.ctx), True)
            self.n_tokens = 0

        def _restore(self, data: bytes) -> bool:
            buffer = (ctypes.c_uint8 * len(data)).from_buffer_copy(data)
            return bool(llama_cpp.llama_state_seq_set_data(self._ctx.ctx, buffer, len(data), 0))

        def _cut(self, data: bytes, n: int) -> bytes:
            """The state ``data`` holding only its first ``n`` tokens (b"" when it fails)."""
            memory = llama_cpp.llama_get_memory(self._ctx.ctx)
            llama_cpp.llama_memory_clear(memory, True)
            if not self._restore(data):
                return b""
            llama_cpp.llama_memory_seq_rm(memory, 0, n, -1)
            return self._seq_data()

        def _seq_data(self) -> bytes:
            ctx = self._ctx.ctx
            size = llama_cpp.llama_state_seq_get_size(ctx, 0)
            buffer = (ctypes.c_uint8 * size)()
            n = llama_cpp.llama_state_seq_get_data(ctx, buffer, size, 0)
            return bytes(buffer)[:n]

        def eval(self, tokens: Sequence[int]) -> None:
            meter = self.meter
            start = time.perf_counter()
            super().eval(tokens)
            if meter is not None:
                meter.evaluated(len(tokens), time.perf_counter() - start)

    return Model


@dataclass
class Meter:
    """What one answer evaluated: its prompt (the first evaluation), then the generation."""

    prompt_evaluated: int = 0
    prompt_seconds: float = 0.0
    evaluations: int = 0
    tokens: int = 0  # evaluated in all

    def evaluated(self, tokens: int, seconds: float) -> None:
        if self.evaluations == 0:
            self.prompt_evaluated, self.prompt_seconds = tokens, seconds
        self.evaluations += 1
        self.tokens += tokens


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
    """The answer to one request: ``ok`` from its kind's handler, or one ``error`` line."""
    ident = message.get("id")
    kinds = [k for k in REQUESTS if k in message]
    if len(kinds) != 1:
        return {"id": ident, "error": f"a request has one kind of {', '.join(REQUESTS)}"}
    try:
        return {"id": ident, "ok": REQUESTS[kinds[0]](llama, message[kinds[0]])}
    except Exception as err:  # one request failed; the worker goes on
        return {"id": ident, "error": _line(err)}


def _complete(llama: Any, body: dict[str, Any]) -> dict[str, Any]:
    """A chat completion; what it evaluated and reused, and the seconds of each phase."""
    kwargs = dict(body)
    with_tokens = bool(kwargs.pop("with_tokens", False))  # the benchmark's audit of reuse
    if kwargs.get("grammar") is not None:
        kwargs["grammar"] = _grammar(llama, kwargs["grammar"])
    if isinstance(llama.cache, KVStates):
        llama.forget()  # only a kept state, restored as a fresh evaluation, is reused
    meter = llama.meter = Meter()
    start = time.perf_counter()
    try:
        out = llama.create_chat_completion(**kwargs)
    finally:
        llama.meter = None
    seconds = time.perf_counter() - start
    usage = out.get("usage") or {}
    choice = out["choices"][0]
    prompt = int(usage.get("prompt_tokens", 0))
    tokens = [int(t) for t in llama.input_ids[: llama.n_tokens]] if with_tokens else None
    return {
        **({"tokens": tokens} if tokens is not None else {}),  # prompt, then the answer
        "text": choice["message"].get("content") or "",
        "prompt_tokens": prompt,
        "completion_tokens": usage.get("completion_tokens", 0),
        "finish_reason": choice.get("finish_reason"),
        "prompt_evaluated": meter.prompt_evaluated,
        "prompt_reused": max(0, prompt - meter.prompt_evaluated),
        "prompt_seconds": round(meter.prompt_seconds, 4),
        "seconds": round(seconds, 4),
    }


def _rates(llama: Any, body: dict[str, Any]) -> dict[str, Any]:
    """llama.cpp's own speed here: ``tokens`` evaluated in batches from an empty context (the
    prompt rate), then ``generate`` tokens decoded one at a time, each the greedy choice of the
    last (the generation rate); nothing else (no chat template, sampler chain or grammar). The
    context is emptied again after it (kept KV states stay)."""
    import numpy as np

    tokens = [int(t) for t in body["tokens"]]
    generate = int(body["generate"])
    if not tokens or generate < 1 or len(tokens) + generate > llama.n_ctx():
        raise ValueError("rates: give 1..n_ctx prompt tokens and generate >= 1")
    llama.reset()
    llama._ctx.kv_cache_seq_rm(-1, 0, -1)
    base: Any = super(type(llama), llama)  # llama-cpp-python's eval (llama_decode), unmetered
    start = time.perf_counter()
    base.eval(tokens)
    prompt_seconds = time.perf_counter() - start
    start = time.perf_counter()
    n_vocab = llama.n_vocab()
    for _ in range(generate):
        logits = np.ctypeslib.as_array(llama._ctx.get_logits(), shape=(n_vocab,))
        base.eval([int(logits.argmax())])
    generate_seconds = time.perf_counter() - start
    llama.reset()
    llama._ctx.kv_cache_seq_rm(-1, 0, -1)
    return {
        "prompt_tokens": len(tokens),
        "prompt_seconds": prompt_seconds,
        "generated": generate,
        "generate_seconds": generate_seconds,
    }


def _score(llama: Any, ask: dict[str, Any]) -> dict[str, Any]:
    """The log-probability of every token of each choice, read from the model's logits after
    the chat prompt (the model's own chat template), the prefix and the choice's earlier tokens.

    Only what the model's cache does not already hold is evaluated: the prompt once (its part
    shared with earlier requests not even that), and of each choice the tokens after those it
    shares with the choice before (``(and (scanned`` is common to many; their log-probabilities,
    the same context and the same tokens, are taken from the choice before). A choice's own
    tokens are decoded one at a time: on a CPU without fast batched kernels a small batch costs
    far more than its tokens one by one. Scores can differ in the last digits with what the
    cache held (batching changes the arithmetic): recorded scores replay exactly.

    ``fresh`` (the benchmark's reference): nothing reused, each choice evaluated with its whole
    prompt from an empty context. The answer says how many tokens were evaluated."""
    prompt = _chat_prompt(llama, ask["messages"]) + str(ask.get("prefix", ""))
    fresh = bool(ask.get("fresh", False))
    base = _tokens(llama, prompt)
    known: dict[int, float] = {}  # position -> log p(token there | the cached tokens before)
    out = []
    meter = llama.meter = Meter()
    try:
        for choice in ask["choices"]:
            tokens = _tokens(llama, prompt + str(choice))
            start = common_prefix(base, tokens)
            if start < 1 or start >= len(tokens):
                raise ValueError(f"choice {choice!r} adds no token to the prompt")
            if fresh:
                known.clear()
                llama.n_tokens = 0
            out.append(_logprobs(llama, tokens, start, known))
    finally:
        llama.meter = None
    return {"logprobs": out, "prompt_tokens": len(base), "evaluated": meter.tokens}


def _logprobs(llama: Any, tokens: list[int], start: int, known: dict[int, float]) -> list[float]:
    """log p(tokens[i] | tokens[:i]) for i >= start: those at positions the cache holds with
    the same tokens from ``known``, the rest decoded one token at a time."""
    import llama_cpp
    import numpy as np

    cached = [int(t) for t in llama.input_ids[: llama.n_tokens]]
    shared = common_prefix(cached, tokens)
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


#: The kinds of request the worker answers: a message ``{"id": N, KIND: body}`` is answered by
#: ``REQUESTS[KIND](llama, body)`` (a JSON object), or by one error line when it raises.
REQUESTS: Mapping[str, Callable[[Any, dict[str, Any]], dict[str, Any]]] = MappingProxyType(
    {"complete": _complete, "rates": _rates, "score": _score}
)


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
