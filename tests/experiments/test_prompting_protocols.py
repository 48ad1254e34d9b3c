"""Table II in two protocols and the ablation of the loop's assists: each variant gets its own
rows, loops and cache keys; the table shows SR with a 95 % interval per variant."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from llmpas.cli import main
from llmpas.experiments.prompting import (
    PromptingConfig,
    jobs_for,
    markdown_table,
    rows,
    summarise,
    wilson,
)
from llmpas.experiments.suite import load_suite
from llmpas.reasoning.assists import Assists


def test_each_protocol_gets_its_rows_loops_and_cache_keys() -> None:
    tasks = load_suite(names=["ol02-table1"])
    config = PromptingConfig(
        llm="openai:m", methods=("flp", "one-step"), samples=1, protocols=("assisted", "paper")
    )
    assert rows(config) == [
        "oracle",
        "replan",
        "flp",
        "one-step",
        "flp [paper]",
        "one-step [paper]",
    ]
    jobs = jobs_for(config, tasks)
    by_row = {j.payload.row or j.payload.method: j for j in jobs}
    assert by_row["flp [paper]"].payload.loop.assists == Assists.none()
    assert by_row["flp"].payload.loop.assists == Assists()
    assert by_row["flp [paper]"].payload.method == "flp"
    assert len({j.key for j in jobs}) == len(jobs)
    # the oracle and replan rows run once, in today's loop
    assert by_row["oracle"].payload.loop.assists == Assists()


def test_the_ablation_runs_no_assist_each_alone_and_all() -> None:
    config = PromptingConfig(llm="openai:m", methods=("flp",), ablation=True, oracle=False)
    shown = rows(config)
    assert shown[:2] == ["replan", "flp"] and "flp [paper]" in shown
    for name in Assists.names():
        assert f"flp [{name}]" in shown
    assert len(shown) == 1 + len(Assists.names()) + 2


@pytest.mark.parametrize("bad", [{"protocols": ()}, {"protocols": ("telepathy",)}, {"votes": 0}])
def test_bad_protocols_are_rejected(bad: dict[str, Any]) -> None:
    with pytest.raises(ValueError):
        PromptingConfig(**bad)


def test_the_interval_is_wilsons() -> None:
    low, high = wilson(3, 10)
    assert round(low, 3) == 0.108 and round(high, 3) == 0.603
    assert wilson(0, 0) == (0.0, 1.0)
    assert wilson(10, 10)[1] == 1.0


def _rec(method: str, task: str, ok: bool) -> dict[str, Any]:
    return {
        "method": method,
        "task": task,
        "category": "object-loss",
        "l_gt": 4,
        "success": ok,
        "verdict": "success" if ok else "not-done",
        "completed": ok,
        "resolution_length": 4,
        "answers": 1,
        "syntax_errors": 0,
        "repairs": 0,
        "tokens": 10,
        "latency": 1.0,
    }


def test_the_table_shows_each_variant_with_its_interval() -> None:
    config = PromptingConfig(
        llm="openai:m",
        methods=("flp",),
        protocols=("paper", "assisted"),
        oracle=False,
        replan=False,
    )
    records = [_rec("flp", "a", True), _rec("flp", "b", True)]
    records += [_rec("flp [paper]", "a", False), _rec("flp [paper]", "b", True)]
    md = markdown_table(summarise(records, rows(config)), config)
    assert "| Method | paper | assisted |" in md
    assert "| flp | 0.50 (0.09–0.91) | 1.00 (0.34–1.00) |" in md


def test_bench_runs_both_protocols_and_the_ablation_with_the_oracle(tmp_path: Path) -> None:
    argv = ["bench", "prompting", "--llm", "oracle", "--methods", "flp", "--tasks", "ol02-table1"]
    argv += ["--samples", "1", "--protocol", "paper", "assisted", "--out", str(tmp_path)]
    assert main(argv) == 0
    md = (tmp_path / "prompting.md").read_text()
    assert "| flp [paper] with the oracle LLM" in md
    assert "| Method | paper | assisted |" in md
