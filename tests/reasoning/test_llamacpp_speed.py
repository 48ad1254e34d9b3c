"""What makes a consultation faster without changing its answers (#30): the KV states the
worker keeps, the threads it takes, and ``llmpas bench llm``'s accounting.

The model tests use the tiny SmolLM2 on the main job's recorded prompts (the offline model is not
in CI); no assertion is about speed, only about tokens evaluated and answers."""

from __future__ import annotations

import os
from collections.abc import Callable, Collection
from pathlib import Path

import numpy as np
import pytest

from llmpas.experiments.llm_bench import (
    DEFAULT_CASSETTES,
    Measured,
    consultations,
    least_evaluated,
    run_setting,
)
from llmpas.reasoning.backends.llamacpp import (
    LlamaSettings,
    free_cores,
    idle_cores,
    settings_before,
)
from llmpas.reasoning.backends.llamacpp_worker import TAIL, KVState, KVStates

from ..tiny_model import needs_tiny_model, smollm2_path

CASSETTES = Path(__file__).parents[1] / "data" / "cassettes" / DEFAULT_CASSETTES.name


def state(*tokens: int) -> KVState:
    return KVState(np.array(tokens), bytes(len(tokens)))


END = tuple(range(100, 100 + TAIL))  # a prompt's last tokens, always evaluated
MORE = tuple(range(200, 210 + TAIL))  # what a repair adds to its conversation


def test_kv_states_give_the_longest_shared_prefix_and_stay_bounded() -> None:
    states = KVStates(2)
    assert states  # Llama tests ``if self.cache``: an empty one still counts
    with pytest.raises(KeyError):
        states[[1, 2, *END]]
    states[[0]] = state(1, 2, 3)  # keyed by what was evaluated, not by the prompt
    states[[0]] = state(1, 2, 9, 9)
    found = states[[1, 2, 9, 5, *END]]  # cut to the shared prefix, holding 4 tokens
    assert list(found.input_ids) == [1, 2, 9] and found.saved == 4
    assert list(states[[1, 2, 3, *END]].input_ids) == [1, 2, 3]
    assert list(states[[1, 2, 3, *END[1:]]].input_ids) == [1, 2]  # the last TAIL: evaluated
    with pytest.raises(KeyError):
        states[[7, 1, 2, *END]]  # no shared prefix
    states[[0]] = state(5)  # the least recently used (1, 2, 9, 9) goes
    assert len(states.states) == 2 and [1, 2, 9, 9] not in states
    assert list(states[[1, 2, 9, *END]].input_ids) == [1, 2]


def proc_stat(*cpus: tuple[int, int]) -> str:
    """A /proc/stat with these (busy, idle) jiffies per CPU (user, nice, system, idle, iowait,
    irq, softirq, steal, guest, guest_nice)."""
    lines = ["cpu  1 2 3 4 5 6 7 8 0 0"]
    for i, (busy, idle) in enumerate(cpus):
        lines.append(f"cpu{i} {busy} 0 0 {idle} 0 0 0 0 0 0")
    return "\n".join([*lines, "intr 12345", "ctxt 99", ""])


def readings(*texts: str) -> Callable[[], str]:
    it = iter(texts)
    return lambda: next(it)


def test_idle_cores_are_read_from_two_samples_of_the_cpu_counters() -> None:
    """cpu0 busy throughout, cpu1 idle, cpu2 half: 1.5 idle cores of {0, 1, 2}; cpu3 is not
    this process's."""
    before = proc_stat((100, 100), (100, 100), (100, 100), (0, 0))
    after = proc_stat((130, 100), (100, 130), (115, 115), (0, 30))
    slept: list[float] = []
    got = idle_cores({0, 1, 2}, readings(before, after), slept.append, 0.25)
    assert got == pytest.approx(1.5) and slept == [0.25]
    assert idle_cores({0, 1, 2, 3}, readings(before, after), slept.append) == pytest.approx(2.5)
    assert idle_cores({0}, readings("garbage", after), slept.append) is None
    assert idle_cores({0}, readings(before, before), slept.append) is None  # nothing moved

    def unreadable() -> str:
        raise OSError("no /proc here")

    assert idle_cores({0}, unreadable, slept.append) is None


def test_threads_are_the_cores_idle_now_not_the_last_minute_s_load(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Right after a busy minute the load average still says 16 of 16 cores are busy; the
    counters say 12 are idle now: 12 threads (shared among the jobs)."""
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(16)))
    monkeypatch.setattr(os, "getloadavg", lambda: (16.0, 8.0, 3.0))
    monkeypatch.delenv("LLMPAS_JOBS", raising=False)
    before = proc_stat(*[(0, 0)] * 16)
    after = proc_stat(*[(100, 0)] * 4, *[(0, 100)] * 12)

    def now(cpus: Collection[int]) -> float | None:
        return idle_cores(cpus, readings(before, after), lambda s: None)

    assert free_cores(sample=now) == 12 and free_cores(4, sample=now) == 3
    assert free_cores(64, sample=now) == 1
    monkeypatch.setenv("LLMPAS_JOBS", "2")  # set in each process of --jobs 2
    assert free_cores(sample=now) == 6
    # where the counters cannot be read: the load average, as before
    assert free_cores(sample=lambda cpus: None) == 1
    monkeypatch.setattr(os, "getloadavg", lambda: (3.7, 0.0, 0.0))
    assert free_cores(sample=lambda cpus: None) == 6
    assert settings_before(LlamaSettings(n_threads=4)).n_threads == 1
    assert LlamaSettings().n_threads == 0  # decided when the model loads


def measured(setting: str, *calls: tuple[int, tuple[int, ...]]) -> list[Measured]:
    return [
        Measured(setting, 0, "goals", "goals", True, n, n, 0, 0, 1.0, 0.5, "", "", tokens)
        for n, tokens in calls
    ]


def test_least_evaluated_reuses_any_earlier_prefix_but_the_last_tokens() -> None:
    first = (1, 2, 3, *END)
    calls = measured(
        "defaults",
        (len(first), (*first, 40)),  # a prompt, then its answer (40)
        (len(first), (1, 5, 6, *END, 41)),
        (len(first) + 1 + len(MORE), (*first, 40, *MORE, 42)),  # the conversation goes on
        (len(first), (*first, 43)),  # the first prompt again: its last TAIL are evaluated
    )
    assert least_evaluated(calls) == [len(first), len(first) - 1, len(MORE), TAIL]


@needs_tiny_model
def test_kv_states_keep_the_answers_and_evaluate_no_prompt_token_twice() -> None:
    """The main job's recorded consultations in the loop's order, before #30 and with the KV
    states kept, and each call alone in a fresh model process (threads alike: only the reuse
    differs). With the states kept: the answers of before (greedy and seeded samples), and of a
    fresh evaluation where the prompt holds no earlier answer (first looks, goals; a repair's
    prompt holds its goals answer, whose tokens were decoded one at a time, before as now);
    fewer prompt tokens evaluated, none that an earlier call had evaluated."""
    model = smollm2_path()
    assert model is not None
    found = consultations(CASSETTES)
    assert [c.kind for c in found[1]] == ["first-look", "goals", "repair"]
    now = LlamaSettings(n_ctx=4096, n_threads=1)
    before, _ = run_setting("before", model, settings_before(now), found)
    after, _ = run_setting("after", model, now, found)
    assert [m.text for m in after] == [m.text for m in before]
    assert any(m.greedy for m in after) and any(not m.greedy for m in after)
    for m in after:
        if m.kind != "repair":
            call = found[m.consultation][[c.tag for c in found[m.consultation]].index(m.tag)]
            assert m.text == run_setting("fresh", model, now, [[call]])[0][0].text, m.tag
    assert [m.prompt_tokens for m in after] == [m.prompt_tokens for m in before]
    assert [m.evaluated for m in after] == least_evaluated(after)  # none twice
    assert sum(m.evaluated for m in after) < sum(m.evaluated for m in before)
    assert all(m.evaluated + m.reused == m.prompt_tokens for m in after)
    goals = [m for m in after if m.kind == "goals"]
    assert all(m.reused > 0 for m in goals[1:])  # the fixed prefix, kept across consultations


def test_strip_evidence_empties_the_anomaly_and_the_first_look() -> None:
    from llmpas.experiments.llm_bench import strip_evidence

    text = (
        "## Task\nthe robot must achieve (and (On cube bowl))\n\n## Anomaly\npick cube failed: "
        "not on table1\n- searched table2\n\n## First look\nIt was moved.\n\n## Output format\nGive"
    )
    out = strip_evidence(text)
    assert "pick cube failed" not in out and "It was moved." not in out
    assert "## Anomaly\n" in out and "## First look\n" in out
    assert out.startswith("## Task\nthe robot must achieve") and out.endswith(
        "## Output format\nGive"
    )


@needs_tiny_model
def test_scoring_reuses_the_shared_prefix_and_scores_as_a_fresh_evaluation() -> None:
    """``bench llm``'s cost per candidate: the worker's scoring evaluates the prompt once and
    each candidate's own tokens; with nothing reused (``fresh``) every candidate evaluates its
    whole prompt. The rankings agree."""
    from llmpas.experiments.llm_bench import SCORE_CASSETTES, score_cases, score_costs

    model = smollm2_path()
    assert model is not None
    case = score_cases(SCORE_CASSETTES, 1)[0]
    short = type(case)(case.name, case.messages, case.prefix, case.choices[:4])
    (cost,) = score_costs(model, LlamaSettings(n_ctx=4096, n_threads=1), [short])
    assert cost.candidates == 4 and cost.prompt_tokens > 100
    assert cost.fresh_evaluated > 3 * cost.prompt_tokens  # every candidate: its whole prompt
    assert cost.reused_evaluated < cost.prompt_tokens + 4 * 40  # the prompt once
    assert cost.same_ranking
