"""``llmpas bench knowledge`` (issue #43 items 2-3): the instrument checked against scripted
OpenAI-compatible servers on loopback. Ten object-loss tasks' first consultations are recorded
once (no model); a server that knows which candidates are effective ranks them first and the
tests say so (p < 0.05); a server that scores at random does not (p > 0.05)."""

from __future__ import annotations

import json
import random
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from llmpas.experiments.knowledge import (
    KnowledgeConfig,
    record,
    run_knowledge,
    shuffled_expectation,
)
from llmpas.experiments.suite import SUITE_DIR
from tests.llm_server import completion_body, scored_body, serve_answers

TASKS = tuple(f"ol{i:02d}-" for i in range(1, 11))


def _names() -> tuple[str, ...]:
    files = sorted(p.stem for p in SUITE_DIR.glob("ol*.toml"))
    return tuple(f for f in files if f.startswith(TASKS))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Any]]:
    out = tmp_path_factory.mktemp("knowledge")
    config = KnowledgeConfig("oracle", ("flp-choose",), tasks=_names(), out_dir=out)
    return out, record(config, Console(quiet=True))


def _answer(recs: list[Any], knowing: bool) -> Any:
    rng = random.Random(0)
    by_anomaly = {r.anomaly: r for r in recs}

    def answer(request: dict[str, Any]) -> bytes:
        grammar = request.get("grammar")
        if not grammar or not request.get("logprobs"):
            return completion_body("The object was moved; look where it may have been put.")
        text = json.loads(grammar.removeprefix("root ::= ").strip())
        prompt = " ".join(str(m.get("content", "")) for m in request["messages"])
        rec = next((r for a, r in by_anomaly.items() if a and a in prompt), None)
        choice = text.split("Goals: ", 1)[-1]
        good = rec is not None and any(
            e and f"(and {c})" == choice for c, e in zip(rec.candidates, rec.effective, strict=True)
        )
        value = (-0.05 if good else -1.5) if knowing else rng.uniform(-2.0, -0.05)
        return scored_body(text, value)

    return answer


def test_the_expectation_of_a_shuffled_order_is_exact() -> None:
    rank, rr, top1 = shuffled_expectation(4, 1)
    assert rank == pytest.approx(2.5) and rr == pytest.approx((1 + 1 / 2 + 1 / 3 + 1 / 4) / 4)
    assert top1 == pytest.approx(0.25)
    assert shuffled_expectation(3, 3) == pytest.approx((1.0, 1.0, 1.0))


def test_the_recorded_consultations_hold_checked_and_effective_candidates(
    recorded: tuple[Path, list[Any]],
) -> None:
    _, recs = recorded
    assert len(recs) == len(_names()) >= 8
    for r in recs:
        assert r.candidates and len(r.effective) == len(r.candidates)
        assert any(r.effective), r.task  # the place it truly is, among the checked looks
        assert not all(r.effective), r.task


@pytest.mark.parametrize("knowing", [True, False])
def test_a_knowing_model_is_found_and_a_random_one_is_not(
    recorded: tuple[Path, list[Any]], knowing: bool, tmp_path: Path
) -> None:
    out, recs = recorded
    with serve_answers(_answer(recs, knowing)) as server:
        config = KnowledgeConfig(
            f"openai:scripted@{server.url}",
            ("flp-choose",),
            tasks=_names(),
            out_dir=out,
        )
        (row,) = run_knowledge(config, Console(quiet=True))
    assert row.tasks == len(recs)
    if knowing:  # two tasks' prompts can be the same (the truth differs): it knows the rest
        assert row.top1 >= row.tasks - 2 and row.mrr > 2 * row.mrr_shuffled
        assert row.p_rank < 0.05 and row.p_top1 < 0.05
    else:
        assert row.p_rank > 0.05 and row.p_top1 > 0.05
    assert (out / "knowledge.md").is_file() and (out / "knowledge.png").stat().st_size > 0
