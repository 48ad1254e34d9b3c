"""The prompting experiment: SR/ASPL exactly as defined, the Table II layout, files, caching."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments import prompting
from llmpas.experiments.prompting import (
    ORACLE,
    REPLAN,
    PromptingConfig,
    build_llm,
    jobs_for,
    markdown_table,
    run_prompting,
    summarise,
)
from llmpas.experiments.suite import load_suite
from llmpas.reasoning.methods import METHODS

QUIET = Console(file=open("/dev/null", "w"))  # noqa: SIM115


def _rec(task: str, cat: str, l_gt: int, ok: bool, length: int, **extra: Any) -> dict[str, Any]:
    return {
        "method": "flp",
        "task": task,
        "category": cat,
        "l_gt": l_gt,
        "success": ok,
        "verdict": "success" if ok else "not-done",
        "completed": ok,
        "resolution_length": length,
        "answers": 1,
        "syntax_errors": 0,
        "repairs": 0,
        "tokens": 100,
        "latency": 1.0,
        **extra,
    }


def test_sr_and_aspl_follow_the_papers_definition() -> None:
    records = [
        # task a: L_gt 5; two of three samples succeed with 5 and 7 actions -> SR 2/3, L̄ 6
        _rec("a", "object-loss", 5, True, 5),
        _rec("a", "object-loss", 5, True, 7),
        _rec("a", "object-loss", 5, False, 3, syntax_errors=1, answers=3, repairs=2),
        # task b: never succeeds -> adds 0 to ASPL (its lengths do not matter)
        _rec("b", "object-loss", 4, False, 40),
        _rec("b", "object-loss", 4, False, 40),
        _rec("b", "object-loss", 4, False, 40),
        # task c (another type): always succeeds with 2 x L_gt
        _rec("c", "state-change", 3, True, 6),
    ]
    cells = {c.category: c for c in summarise(records, ["flp"])}
    ol = cells["object-loss"]
    assert ol.tasks == 2 and ol.samples == 6
    assert ol.sr == pytest.approx((2 / 3 + 0) / 2)
    assert ol.aspl == pytest.approx((6 / 5 * 2 / 3 + 0) / 2)
    assert ol.syntax_error_rate == pytest.approx(1 / 8)  # 1 of 8 goal answers
    assert ol.repairs == pytest.approx(2 / 6)
    assert ol.completion == pytest.approx(2 / 6)
    sc = cells["state-change"]
    assert sc.sr == 1.0 and sc.aspl == pytest.approx(2.0)
    assert "action-blocking" not in cells
    assert cells["all"].tasks == 3 and cells["all"].samples == 7


def test_markdown_has_the_table_ii_layout() -> None:
    records = [
        {**_rec("a", "object-loss", 5, True, 5), "method": ORACLE, "first_effective": True},
        {**_rec("b", "action-blocking", 4, True, 4), "method": ORACLE, "first_effective": True},
        {**_rec("c", "state-change", 3, True, 3), "method": ORACLE, "first_effective": True},
        {**_rec("a", "object-loss", 5, False, 0), "method": REPLAN, "first_effective": False},
        {**_rec("b", "action-blocking", 4, True, 4), "method": REPLAN, "first_effective": False},
        {**_rec("c", "state-change", 3, True, 3), "method": REPLAN, "first_effective": False},
        _rec("a", "object-loss", 5, False, 0, first_effective=False),
        _rec("b", "action-blocking", 4, True, 8, first_effective=True),
        _rec("c", "state-change", 3, True, 3),  # a task without effective sets: not counted
    ]
    config = PromptingConfig(llm="openai:x", methods=("flp",))
    text = markdown_table(summarise(records, [ORACLE, REPLAN, "flp"]), config)
    assert (
        "| Method | Object Loss SR | Object Loss ASPL | Object Loss 1st eff. "
        "| Action Blocking SR | Action Blocking ASPL | Action Blocking 1st eff. "
        "| State Change SR | State Change ASPL | State Change 1st eff. |" in text
    )
    assert (
        "| oracle (upper bound) | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 |"
        in text
    )
    replan = "| replan (no reasoning: the task restated) |"
    assert f"{replan} 0.00 | 0.00 | 0.00 | 1.00 | 1.00 | 0.00 | 1.00 | 1.00 | 0.00 |" in text
    assert "| flp | 0.00 | 0.00 | 0.00 | 1.00 | 2.00 | 1.00 | 1.00 | 1.00 | — |" in text
    # the lift over replan: per type and overall; only methods have one
    assert "| Method | Object Loss | Action Blocking | State Change | all |" in text
    assert "| flp | +0.00 | +0.00 | +0.00 | +0.00 |" in text
    # all: SR, its 95 % (Wilson) interval over the pooled samples, ASPL, 1st eff., lift
    assert f"{replan} 0.67 | 0.21–0.94 | 0.67 | 0.00 | — |" in text
    assert "| flp | 0.67 | 0.21–0.94 | 1.00 | 0.50 | +0.00 |" in text


def test_lift_is_the_sr_difference_with_the_replan_row_per_type_and_overall() -> None:
    records = [
        {**_rec("a", "object-loss", 5, False, 0), "method": REPLAN},
        {**_rec("b", "object-loss", 5, True, 5), "method": REPLAN},
        {**_rec("c", "state-change", 3, True, 3), "method": REPLAN},
        _rec("a", "object-loss", 5, True, 5),
        _rec("a", "object-loss", 5, True, 5),
        _rec("b", "object-loss", 5, True, 5),
        _rec("b", "object-loss", 5, False, 0),
        _rec("c", "state-change", 3, False, 0),
    ]
    cells = {(c.method, c.category): c for c in summarise(records, [REPLAN, "flp"])}
    assert cells[("flp", "object-loss")].lift == pytest.approx((1 + 0.5) / 2 - 0.5)
    assert cells[("flp", "state-change")].lift == pytest.approx(-1.0)
    assert cells[("flp", "all")].lift == pytest.approx((1 + 0.5 + 0) / 3 - 2 / 3)
    assert all(c.lift is None for (m, _), c in cells.items() if m == REPLAN)
    # without a replan row there is nothing to lift over
    assert all(c.lift is None for c in summarise(records[3:], ["flp"]))


@pytest.mark.parametrize(
    "bad",
    [
        {"methods": ("nosuch",)},
        {"methods": ("flp", "flp")},
        {"methods": (), "oracle": False, "replan": False},
        {"samples": 0},
        {"temperature": 3.0},
        {"jobs": 0},
        {"max_rounds": 0},
        {"tasks": ()},
        {"decoding": "magic"},
    ],
)
def test_bad_configurations_are_rejected(bad: dict[str, Any]) -> None:
    with pytest.raises(ValueError):
        PromptingConfig(**bad)


def test_jobs_cover_methods_tasks_and_samples_with_distinct_seeds() -> None:
    tasks = load_suite(names=["ol02-table1", "sc02-apple-stove"])
    config = PromptingConfig(llm="openai:m", methods=("flp", "one-step"), samples=3)
    jobs = jobs_for(config, tasks)
    # the oracle and replan: one deterministic sample per task
    assert len(jobs) == 2 * 1 + 2 * 1 + 2 * 2 * 3
    seeds = {j.payload.loop.method.seed for j in jobs if j.payload.method == "flp"}
    assert seeds == {0, 1, 2}
    assert all(j.payload.llm == ORACLE for j in jobs if j.payload.method == ORACLE)
    replan = [j for j in jobs if j.payload.method == REPLAN]
    assert len(replan) == 2 and all(j.payload.llm == REPLAN and not j.resources for j in replan)
    # the same loop and budget as the oracle row
    assert {j.payload.loop for j in replan} == {
        j.payload.loop for j in jobs if j.payload.method == ORACLE
    }
    assert all(j.payload.loop.method.temperature == 0.7 for j in jobs if j.payload.method == "flp")
    # a changed configuration never reuses cached results
    other = jobs_for(PromptingConfig(llm="openai:m", methods=("flp",), repairs=0), tasks)
    assert not {j.key for j in jobs if j.payload.method == "flp"} & {j.key for j in other}


def test_bad_llm_specs_are_value_errors() -> None:
    with pytest.raises(ValueError, match="expected oracle"):
        build_llm("nosuch:model")
    assert callable(build_llm(ORACLE))


def test_bench_writes_table_csv_plot_and_resumes_from_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    argv = [
        "bench",
        "prompting",
        "--llm",
        "oracle",
        "--methods",
        "flp",
        "--tasks",
        "ol02-table1",
        "--samples",
        "2",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    names = {p.name for p in out.iterdir()}
    assert {
        "prompting.md",
        "prompting.csv",
        "prompting.json",
        "prompting_samples.csv",
        "prompting.png",
    } <= names
    assert (out / "prompting.png").read_bytes().startswith(b"\x89PNG")
    rows = list(csv.DictReader((out / "prompting.csv").open()))
    assert {(r["method"], r["category"]) for r in rows} == {
        (m, c) for m in ("oracle", "replan", "flp") for c in ("object-loss", "all")
    }
    solved = [r for r in rows if r["method"] != REPLAN]
    assert all(float(r["sr"]) == 1.0 for r in solved)
    # L̄ / L_gt: l_gt is the shortest over fixed hash seeds, this process's may plan longer
    assert all(0.5 < float(r["aspl"]) < 1.5 for r in solved)
    # replan cannot find the lost mug: SR 0, its first proposal (the task) is not effective
    assert all(float(r["sr"]) == 0.0 for r in rows if r["method"] == REPLAN)
    assert all(float(r["first_effective"]) == 0.0 for r in rows if r["method"] == REPLAN)
    assert all(float(r["lift"]) == 1.0 for r in rows if r["method"] == "flp")
    samples = list(csv.DictReader((out / "prompting_samples.csv").open()))
    assert len(samples) == 1 + 1 + 2
    md = (out / "prompting.md").read_text()
    assert "| oracle (upper bound) |" in md and "| replan (no reasoning" in md
    data = json.loads((out / "prompting.json").read_text())
    flp_all = next(c for c in data["cells"] if (c["method"], c["category"]) == ("flp", "all"))
    assert flp_all["lift"] == 1.0 and flp_all["first_effective"] == 1.0
    assert len(list((out / "cache").glob("*.json"))) == 4

    def no_more_work(payload: object) -> dict[str, Any]:
        raise AssertionError("a cached job ran again")

    monkeypatch.setattr(prompting, "run_job", no_more_work)
    config = PromptingConfig(
        llm=ORACLE, methods=("flp",), tasks=("ol02-table1",), samples=2, out_dir=out
    )
    again = run_prompting(config, QUIET)
    assert len(again.records) == 4
    assert [r["success"] for r in again.records if r["method"] != REPLAN] == [True] * 3


def test_all_methods_are_offered() -> None:
    values: dict[str, Any] = {
        "llm": "oracle",
        "methods": ["all"],
        "no_oracle": False,
        "samples": 1,
        "temperature": 0.5,
        "seed": 0,
        "decoding": "grammar",
        "repairs": 2,
        "rounds": 3,
        "max_time": 60.0,
        "suite": str(prompting.SUITE_DIR),
        "tasks": None,
        "record": None,
        "jobs": 2,
        "out": "x",
    }
    config = prompting.config_from_args(prompting.argparse.Namespace(**values))
    assert config.methods == tuple(METHODS) and config.jobs == 2 and config.oracle
    only_oracle = prompting.config_from_args(
        prompting.argparse.Namespace(**{**values, "methods": ["none"]})
    )
    assert only_oracle.methods == () and only_oracle.oracle
