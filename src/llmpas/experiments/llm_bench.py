"""``llmpas bench llm``: the offline model on the prompts the loop really sends.

The prompts are recorded ones (a cassette folder, by default the main job's published
cassettes): each recorded goals request with its first look before it and its repairs after
it is one *consultation*, sent in the loop's order (first look, goals, repair-1, repair-2).
Every setting answers all of them in one run, each in a fresh model process:

- ``before``: the settings before #30 (one thread; only the last answer's KV state kept, so a
  prompt reuses only the prefix it shares with the call just before);
- ``defaults``: today's defaults (:class:`~llmpas.reasoning.backends.llamacpp.LlamaSettings`:
  threads from the free cores, KV states kept across answers);
- ``limit``: llama.cpp at its best here: the rates of its own decoding loop (``llama_decode`` in
  batches for a prompt, one token at a time for an answer, greedy, no chat template, sampler
  chain or grammar, threads = the free cores) applied to the least work the same answers need:
  each prompt token evaluated once (a prefix any earlier call evaluated is reused) and the
  tokens the defaults generated.

- ``busy-load`` and ``busy-idle`` (``--busy SECONDS``, default 60; 0 leaves them out): each
  started right after a busy minute (every core this process may use spinning), its threads
  from the 1-minute load average (the rule before #36, which still counts the minute that just
  ended) and from a short sample of idle CPU (today's rule, :func:`~llmpas.reasoning.backends.
  llamacpp.free_cores`).

Scoring candidates (``flp-choose``, ``--scores N`` recorded score requests, default 3, from
``--score-cassettes``): each scored in one model process with the shared prefix evaluated once
(the worker's KV reuse: the prompt once, the text candidates share once), and again with nothing
reused (each candidate with its whole prompt from an empty context); and the prompt without the
evidence (what ``pmi`` scores too): the cost per candidate of each, and their ratio.

Per setting and call kind the table gives the prompt tokens evaluated and reused, the tokens
generated, the seconds, and the prompt and generation rates; then the seconds per consultation,
the ratios, whether the defaults' answers are the same as before (greedy and sampled apart), and
how many prompt tokens the defaults evaluated that an earlier call had evaluated already.
Writes ``llm.md``, ``llm.csv`` (one row per call and setting) and ``llm.png``.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.experiments.benchmarks import AllConfig
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.options import positive_int
from llmpas.reasoning.llm import LLMError, Message, Request

log = logging.getLogger(__name__)

DEFAULT_CASSETTES = Path("tests/data/cassettes/qwen1.5b")  # the main job's, in the repository
SCORE_CASSETTES = Path("tests/data/cassettes/qwen1.5b-suite")  # flp-choose's recorded scores
KINDS = ("first-look", "goals", "repair")
SETTINGS = ("before", "defaults", "limit", "busy-load", "busy-idle")
BUSY_LABELS = {
    "busy-load": "started right after a busy minute, threads from the load average",
    "busy-idle": "started right after a busy minute, threads from the idle CPU now",
}
RATE_GENERATE = 32  # tokens decoded one at a time to measure the generation rate


@dataclass(frozen=True)
class Call:
    """One recorded request of a consultation: its kind and what was answered when recorded."""

    kind: str  # first-look | goals | repair
    tag: str
    request: Request
    recorded: str


@dataclass(frozen=True)
class Measured:
    """One call answered under one setting."""

    setting: str
    consultation: int
    kind: str
    tag: str
    greedy: bool
    prompt_tokens: int
    evaluated: int
    reused: int
    generated: int
    seconds: float  # the whole answer, as the caller waited for it
    prompt_seconds: float
    text: str
    recorded: str
    tokens: tuple[int, ...] = ()  # prompt then answer, as evaluated

    def row(self) -> dict[str, Any]:
        return {
            "setting": self.setting,
            "consultation": self.consultation,
            "call": self.tag,
            "greedy": self.greedy,
            "prompt_tokens": self.prompt_tokens,
            "evaluated": self.evaluated,
            "reused": self.reused,
            "generated": self.generated,
            "seconds": round(self.seconds, 3),
            "prompt_seconds": round(self.prompt_seconds, 3),
            "same_as_recorded": self.text == self.recorded,
            "text": self.text,
        }


def _request(data: dict[str, Any]) -> Request:
    r = data["request"]
    return Request(
        tuple(Message(m["role"], m["content"]) for m in r["messages"]),
        temperature=r["temperature"],
        max_tokens=r["max_tokens"],
        seed=r["seed"],
        grammar=r.get("grammar"),
        json_schema=r.get("json_schema"),
        tag=data.get("tag") or "",
    )


def consultations(folder: Path) -> list[list[Call]]:
    """The consultations recorded in ``folder``: each goals request, after the first look its
    prompt quotes and before the repairs that continue its conversation (votes left out)."""
    calls: list[Call] = []
    for path in sorted(folder.glob("*.json")):
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            tag = str(data.get("tag") or "")
            call = Call(_kind(tag), tag, _request(data), str(data["response"]["text"]))
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise ValueError(f"{path}: not a cassette ({type(err).__name__}: {err})") from None
        if call.kind:
            calls.append(call)
    looks = [c for c in calls if c.kind == "first-look"]
    repairs = sorted((c for c in calls if c.kind == "repair"), key=lambda c: c.tag)
    found = []
    for goals in (c for c in calls if c.kind == "goals"):
        prompt = goals.request.messages[-1].content
        look = [c for c in looks if c.recorded.strip() and c.recorded.strip() in prompt]
        chain = [*look[:1], goals]
        for repair in repairs:
            previous = chain[-1].request.messages
            if repair.request.messages[: len(previous)] == previous:
                chain.append(repair)
        found.append(chain)
    return found


def _kind(tag: str) -> str:
    if tag in ("first-look", "goals"):
        return tag
    return "repair" if tag.startswith("repair-") else ""


def run_setting(
    name: str, model: Path, settings: Any, consultations: Sequence[Sequence[Call]]
) -> tuple[list[Measured], dict[str, Any] | None]:
    """Every call answered under ``settings`` in one model process, in order; with the rates
    of llama.cpp's own loop measured in that process after them (``name == "defaults"``)."""
    from llmpas.reasoning.backends.llamacpp import LlamaCppBackend, request_kwargs

    out: list[Measured] = []
    rates = None
    with LlamaCppBackend(model, settings=settings) as llm:
        for number, chain in enumerate(consultations):
            for call in chain:
                body = {**request_kwargs(call.request, settings.seed), "with_tokens": True}
                ok, seconds = llm.ask("complete", body)
                out.append(_measured(name, number, call, ok, seconds))
                log.info("%s #%d %s: %.1f s", name, number, call.tag, seconds)
        if name == "defaults" and out:
            longest = max(out, key=lambda m: m.prompt_tokens)
            prompt = list(longest.tokens[: longest.prompt_tokens])
            rates, _ = llm.ask("rates", {"tokens": prompt, "generate": RATE_GENERATE})
    return out, rates


def _measured(name: str, number: int, call: Call, ok: dict[str, Any], seconds: float) -> Measured:
    prompt = int(ok.get("prompt_tokens") or 0)
    evaluated = int(ok.get("prompt_evaluated") or 0)
    return Measured(
        setting=name,
        consultation=number,
        kind=call.kind,
        tag=call.tag,
        greedy=call.request.temperature == 0,
        prompt_tokens=prompt,
        evaluated=evaluated,
        reused=int(ok.get("prompt_reused") or 0),
        generated=int(ok.get("completion_tokens") or 0),
        seconds=seconds,
        prompt_seconds=float(ok.get("prompt_seconds") or 0.0),
        text=str(ok.get("text") or ""),
        recorded=call.recorded,
        tokens=tuple(int(t) for t in ok.get("tokens") or ()),
    )


def least_evaluated(measured: Sequence[Measured]) -> list[int]:
    """Per call, the prompt tokens no earlier call evaluated (the longest prefix shared with
    what an earlier call evaluated is reused), but its last few, which are evaluated so that the
    logits stay those of a batch (:data:`~llmpas.reasoning.backends.llamacpp_worker.TAIL`)."""
    from llmpas.reasoning.backends.llamacpp_worker import TAIL, common_prefix

    least = []
    for i, m in enumerate(measured):
        prompt = m.tokens[: m.prompt_tokens]
        shared = max((common_prefix(prompt, e.tokens) for e in measured[:i]), default=0)
        least.append(m.prompt_tokens - min(shared, max(0, m.prompt_tokens - TAIL)))
    return least


def limit_row(defaults: Sequence[Measured], rates: dict[str, Any]) -> list[Measured]:
    """The defaults' calls at llama.cpp's own rates, each prompt token evaluated once."""
    prompt_rate = rates["prompt_tokens"] / rates["prompt_seconds"]
    generate_rate = rates["generated"] / rates["generate_seconds"]
    out = []
    for m, least in zip(defaults, least_evaluated(defaults), strict=True):
        prompt_seconds = least / prompt_rate
        seconds = prompt_seconds + m.generated / generate_rate
        out.append(
            replace(
                m,
                setting="limit",
                evaluated=least,
                reused=m.prompt_tokens - least,
                seconds=seconds,
                prompt_seconds=prompt_seconds,
            )
        )
    return out


@dataclass(frozen=True)
class Summary:
    """One setting and call kind (``kind == "all"``: every call)."""

    setting: str
    kind: str
    calls: int
    evaluated: int
    reused: int
    generated: int
    seconds: float
    prompt_seconds: float

    @property
    def prompt_rate(self) -> float | None:
        return self.evaluated / self.prompt_seconds if self.prompt_seconds > 0 else None

    @property
    def generation_rate(self) -> float | None:
        rest = self.seconds - self.prompt_seconds
        return self.generated / rest if rest > 0 else None


def summarise(measured: Sequence[Measured]) -> list[Summary]:
    rows = []
    for setting in SETTINGS:
        for kind in (*KINDS, "all"):
            ms = [m for m in measured if m.setting == setting and kind in (m.kind, "all")]
            if ms:
                rows.append(
                    Summary(
                        setting,
                        kind,
                        len(ms),
                        sum(m.evaluated for m in ms),
                        sum(m.reused for m in ms),
                        sum(m.generated for m in ms),
                        sum(m.seconds for m in ms),
                        sum(m.prompt_seconds for m in ms),
                    )
                )
    return rows


def per_consultation(measured: Sequence[Measured], setting: str) -> float | None:
    """Mean seconds of one consultation (its calls together)."""
    totals: dict[int, float] = {}
    for m in measured:
        if m.setting == setting:
            totals[m.consultation] = totals.get(m.consultation, 0.0) + m.seconds
    return statistics.mean(totals.values()) if totals else None


def markdown(measured: Sequence[Measured], about: dict[str, Any]) -> str:
    lines = [
        "# The offline model on the loop's recorded prompts",
        "",
        f"Model `{about['model']}`; prompts: `{about['cassettes']}` ({about['consultations']} "
        f"consultations, {about['calls']} calls); threads: before 1, defaults and limit "
        f"{about['threads']} (free cores when measured; load average {about['load']}).",
        *[
            f"{name}: {BUSY_LABELS[name]}: {threads} threads."
            for name, threads in about.get("busy", {}).items()
        ],
        "",
        "| setting | call | calls | prompt tokens evaluated | reused | generated | seconds "
        "| prompt tok/s | generation tok/s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summarise(measured):
        lines.append(
            f"| {s.setting} | {s.kind} | {s.calls} | {s.evaluated} | {s.reused} | {s.generated} "
            f"| {s.seconds:.1f} | {_rate(s.prompt_rate)} | {_rate(s.generation_rate)} |"
        )
    before = per_consultation(measured, "before")
    defaults = per_consultation(measured, "defaults")
    limit = per_consultation(measured, "limit")
    lines += ["", "Seconds per consultation (mean):", ""]
    for name in SETTINGS:
        value = per_consultation(measured, name)
        if value is not None or name in ("before", "defaults", "limit"):
            lines.append(f"- {name}: {value:.1f} s" if value is not None else f"- {name}: -")
    busy = per_consultation(measured, "busy-load")
    idle = per_consultation(measured, "busy-idle")
    if busy and idle:
        lines.append(
            f"- started right after a busy minute: threads from the idle CPU are "
            f"{busy / idle:.2f}x as fast as threads from the load average"
        )
    if before and defaults:
        lines.append(f"- defaults are {before / defaults:.2f}x as fast as before")
    if limit and defaults:
        lines.append(f"- defaults take {defaults / limit:.2f}x the limit's time")
    lines += ["", *_answers(measured)]
    return "\n".join(lines) + "\n"


def _answers(measured: Sequence[Measured]) -> list[str]:
    by = {(m.setting, m.consultation, m.tag): m for m in measured}
    pairs = [
        (m, by[("defaults", m.consultation, m.tag)])
        for m in measured
        if m.setting == "before" and ("defaults", m.consultation, m.tag) in by
    ]
    lines = []
    for label, greedy in (("greedy", True), ("sampled (repairs)", False)):
        ps = [(a, b) for a, b in pairs if a.greedy == greedy]
        if ps:
            same = sum(a.text == b.text for a, b in ps)
            lines.append(f"- {label} answers the same as before: {same} of {len(ps)}")
    defaults = [m for m in measured if m.setting == "defaults"]
    if defaults:
        twice = sum(
            m.evaluated - least
            for m, least in zip(defaults, least_evaluated(defaults), strict=True)
        )
        lines.append(f"- prompt tokens the defaults evaluated that an earlier call had: {twice}")
    for setting in ("before", "defaults"):
        ms = [m for m in measured if m.setting == setting]
        if ms:
            same = sum(m.text == m.recorded for m in ms)
            lines.append(f"- {setting}: answers equal to the recorded ones: {same} of {len(ms)}")
    return lines


def _rate(value: float | None) -> str:
    return f"{value:.1f}" if value is not None else "-"


def plot(measured: Sequence[Measured], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = len({m.consultation for m in measured}) or 1
    fig, ax = plt.subplots(figsize=(7, 4))
    settings = [s for s in SETTINGS if any(m.setting == s for m in measured)]
    bottoms = [0.0] * len(settings)
    for kind in KINDS:
        heights = [
            sum(m.seconds for m in measured if m.setting == s and m.kind == kind) / count
            for s in settings
        ]
        ax.bar(settings, heights, bottom=bottoms, label=kind)
        bottoms = [b + h for b, h in zip(bottoms, heights, strict=True)]
    ax.set_ylabel("seconds per consultation (mean)")
    ax.set_title("offline model on the loop's recorded prompts")
    ax.legend()
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def busy(seconds: float) -> None:
    """Every core this process may use spinning for ``seconds`` (a process each, killed after)."""
    import subprocess
    import sys
    import time

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    spin = [sys.executable, "-c", "while True: pass"]
    procs = [subprocess.Popen(spin) for _ in range(cores or 1)]
    try:
        time.sleep(seconds)
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def busy_rows(
    model: Path, defaults: Any, found: Sequence[Sequence[Call]], seconds: float
) -> tuple[list[Measured], dict[str, int]]:
    """The consultations answered right after a busy minute, twice: threads from the load
    average (the rule before #36) and from the idle CPU sampled when the model loads."""
    from llmpas.reasoning.backends.llamacpp import free_cores

    out: list[Measured] = []
    threads = {}
    for name in ("busy-load", "busy-idle"):
        busy(seconds)
        n = free_cores(sample=lambda cpus: None) if name == "busy-load" else free_cores()
        threads[name] = n
        out += run_setting(name, model, replace(defaults, n_threads=n), found)[0]
    return out, threads


def run_bench(
    model: Path,
    cassettes: Path,
    out: Path,
    limit: int | None,
    console: Console,
    busy_seconds: float = 0.0,
    scores: tuple[Path, int] | None = None,
) -> list[Path]:
    from llmpas.reasoning.backends.llamacpp import LlamaSettings, free_cores, settings_before

    found = consultations(cassettes)[:limit]
    if not found:
        raise ValueError(f"--cassettes {cassettes}: no recorded goals request")
    defaults = replace(LlamaSettings(), n_threads=free_cores())
    before = settings_before(defaults)
    measured: list[Measured] = []
    with console.status("before: the settings before #30 ..."):
        measured += run_setting("before", model, before, found)[0]
    with console.status("defaults ..."):
        rows, rates = run_setting("defaults", model, defaults, found)
    measured += rows
    if rates is not None:
        measured += limit_row(rows, rates)
    busy_threads: dict[str, int] = {}
    if busy_seconds > 0:
        with console.status(f"busy for {busy_seconds:g} s, then the model (twice) ..."):
            more, busy_threads = busy_rows(model, defaults, found, busy_seconds)
        measured += more
    scored: list[ScoreCost] = []
    if scores is not None and scores[1] > 0:
        with console.status("scoring candidates ..."):
            scored = score_costs(model, defaults, score_cases(scores[0], scores[1]))
    about = {
        "model": model.name,
        "cassettes": str(cassettes),
        "consultations": len(found),
        "calls": sum(len(c) for c in found),
        "threads": defaults.n_threads,
        "load": " / ".join(f"{x:.2f}" for x in os.getloadavg()),
        "busy": busy_threads,
    }
    out.mkdir(parents=True, exist_ok=True)
    text = markdown(measured, about) + score_markdown(scored)
    files = [
        atomic_write(out / "llm.md", text),
        write_csv(out / "llm.csv", [m.row() for m in measured]),
    ]
    plot(measured, out / "llm.png")
    return [*files, out / "llm.png"]


# ------------------------------------------------------------------------- scoring's cost


@dataclass(frozen=True)
class ScoreCase:
    """A recorded score request: the chat, the prefix and the candidates."""

    name: str
    messages: tuple[Message, ...]
    prefix: str
    choices: tuple[str, ...]


@dataclass(frozen=True)
class ScoreCost:
    """One score request measured three ways in one model process."""

    name: str
    candidates: int
    prompt_tokens: int
    reused_seconds: float  # the worker's scoring: the shared prefix evaluated once
    reused_evaluated: int
    fresh_seconds: float  # nothing reused: each candidate with its whole prompt
    fresh_evaluated: int
    prior_seconds: float  # the prompt without the evidence (pmi's second scoring), reused
    same_ranking: bool  # reused and fresh rank the candidates alike


def score_cases(folder: Path, limit: int) -> list[ScoreCase]:
    """The first ``limit`` recorded score requests of ``folder`` (by file name)."""
    out = []
    for path in sorted(folder.glob("*.json")):
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("kind") != "score":
                continue
            r = data["request"]
            messages = tuple(Message(m["role"], m["content"]) for m in r["messages"])
            case = ScoreCase(path.stem[:12], messages, str(r["prefix"]), tuple(r["choices"]))
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise ValueError(f"{path}: not a cassette ({type(err).__name__}: {err})") from None
        out.append(case)
        if len(out) >= limit:
            break
    return out


def strip_evidence(text: str) -> str:
    """A recorded goals prompt without its evidence: the ``## Anomaly`` and ``## First look``
    sections emptied (what ``pmi`` and ``prior`` score against)."""
    import re

    return re.sub(r"(## (?:Anomaly|First look)\n).*?(?=\n## |\Z)", r"\1", text, flags=re.S)


def score_costs(model: Path, settings: Any, cases: Sequence[ScoreCase]) -> list[ScoreCost]:
    from llmpas.reasoning.backends.llamacpp import LlamaCppBackend

    out = []
    with LlamaCppBackend(model, settings=settings) as llm:
        for case in cases:
            messages = [{"role": m.role, "content": m.content} for m in case.messages]
            body: dict[str, Any] = {
                "messages": messages,
                "prefix": case.prefix,
                "choices": list(case.choices),
            }
            # as the loop asks: the scoring, then (pmi) the prompt without the evidence; then
            # the reference with nothing reused
            reused, reused_s = llm.ask("score", body)
            last = messages[-1]
            blind = [*messages[:-1], {**last, "content": strip_evidence(last["content"])}]
            _, prior_s = llm.ask("score", {**body, "messages": blind})
            fresh, fresh_s = llm.ask("score", {**body, "fresh": True})
            out.append(
                ScoreCost(
                    case.name,
                    len(case.choices),
                    int(reused.get("prompt_tokens") or 0),
                    reused_s,
                    int(reused.get("evaluated") or 0),
                    fresh_s,
                    int(fresh.get("evaluated") or 0),
                    prior_s,
                    _ranking(reused["logprobs"]) == _ranking(fresh["logprobs"]),
                )
            )
            log.info("scored %s: %.1f s reused, %.1f s fresh", case.name, reused_s, fresh_s)
    return out


def _ranking(logprobs: Sequence[Sequence[float]]) -> list[int]:
    means = [sum(lp) / len(lp) if lp else float("-inf") for lp in logprobs]
    return sorted(range(len(means)), key=lambda i: (-means[i], i))


def score_markdown(costs: Sequence[ScoreCost]) -> str:
    """The cost per candidate of scoring, with and without the shared prefix's reuse."""
    if not costs:
        return ""
    lines = [
        "",
        "## Scoring candidates: cost per candidate",
        "",
        "Recorded `flp-choose` score requests, each scored in one model process with the "
        "shared prefix evaluated once (reused), with nothing reused (fresh), and the prompt "
        "without the evidence (prior: `pmi` scores it too, `prior` only it).",
        "",
        "| request | candidates | prompt tokens | evaluated reused / fresh | s per candidate "
        "reused | fresh | prior | pmi (reused + prior) | same ranking |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for c in costs:
        n = max(1, c.candidates)
        lines.append(
            f"| {c.name} | {c.candidates} | {c.prompt_tokens} | {c.reused_evaluated} / "
            f"{c.fresh_evaluated} | {c.reused_seconds / n:.2f} | {c.fresh_seconds / n:.2f} | "
            f"{c.prior_seconds / n:.2f} | {(c.reused_seconds + c.prior_seconds) / n:.2f} | "
            f"{'yes' if c.same_ranking else 'no'} |"
        )
    n = sum(c.candidates for c in costs) or 1
    reused = sum(c.reused_seconds for c in costs)
    fresh = sum(c.fresh_seconds for c in costs)
    lines += [
        "",
        f"- seconds per candidate: reused {reused / n:.2f}, fresh {fresh / n:.2f}"
        + (f" (the reuse makes scoring {fresh / reused:.1f}x as fast)" if reused > 0 else ""),
    ]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------ CLI


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench llm``."""
    p.add_argument("--model", help="a GGUF file (default: the offline model)")
    p.add_argument(
        "--cassettes",
        default=str(DEFAULT_CASSETTES),
        help="recorded requests: a cassette folder (default: the main job's)",
    )
    p.add_argument("--consultations", type=positive_int, help="only the first N consultations")
    p.add_argument(
        "--busy",
        type=float,
        default=60.0,
        help="seconds every core spins before each of the two rows started right after a busy "
        "minute (0: leave them out)",
    )
    p.add_argument(
        "--score-cassettes",
        default=str(SCORE_CASSETTES),
        help="recorded score requests (flp-choose's): a cassette folder",
    )
    p.add_argument(
        "--scores", type=int, default=3, help="score requests measured (0: leave them out)"
    )


@dataclass(frozen=True)
class LlmBenchConfig:
    """One ``llmpas bench llm``: the model, the recorded requests, where it writes, the first
    ``consultations`` (None: all), the busy rows' seconds and the score requests measured."""

    model: Path
    cassettes: Path
    out_dir: Path
    consultations: int | None
    busy: float
    scores: tuple[Path, int]


def config_from(args: argparse.Namespace, shared: Shared) -> LlmBenchConfig:
    """The config of ``llmpas bench llm``'s options (ValueError / LLMError: one line)."""
    from llmpas.reasoning.models import DEFAULT_MODEL, model_path

    cassettes = Path(args.cassettes)
    if not cassettes.is_dir():
        raise ValueError(f"--cassettes {cassettes}: no such folder")
    model = Path(args.model) if args.model else model_path(DEFAULT_MODEL)
    if not model.is_file():
        raise LLMError(f"model file {model} not found: run `llmpas model install`")
    if not args.busy >= 0 or args.scores < 0:
        raise ValueError("--busy and --scores must be >= 0")
    score_folder = Path(args.score_cassettes)
    if args.scores and not score_folder.is_dir():
        raise ValueError(f"--score-cassettes {score_folder}: no such folder")
    return LlmBenchConfig(
        model, cassettes, shared.out_dir, args.consultations, args.busy, (score_folder, args.scores)
    )


def _run(c: LlmBenchConfig, console: Console) -> list[Path]:
    return run_bench(c.model, c.cassettes, c.out_dir, c.consultations, console, c.busy, c.scores)


def _in_all(config: AllConfig) -> tuple[str, ...] | None:
    return None  # it needs the offline model and minutes of it: run on its own


BENCHMARK = Harnessed(
    "llm",
    "the offline model on the loop's recorded prompts: settings before, defaults, limit",
    add_arguments,
    config_from,
    _run,
    SharedOptions(out="results/llm", jobs=False, executor=False),
    _in_all,
)
