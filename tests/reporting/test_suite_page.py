"""The page of ``llmpas bench prompting``: Table II with links to the samples and kept runs."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from llmpas.experiments.prompting import PromptingConfig, summarise
from llmpas.experiments.prompting_page import render_page
from llmpas.reporting import browser, read_run

from .conftest import HOSTILE


def _links(page: str) -> list[str]:
    return re.findall(r'href="([^"]+)"', page)


def test_each_cell_links_to_its_samples_and_each_sample_to_its_run(suite_run: Path) -> None:
    page = (suite_run / "index.html").read_text(encoding="utf-8")
    anchors = [h[1:] for h in _links(page) if h.startswith("#")]
    assert len(anchors) == 6  # (oracle, replan, flp) x (object loss, all)
    assert all(f'id="{a}"' in page for a in anchors)
    runs = [h for h in _links(page) if h.endswith("index.html")]
    assert len(runs) == 3  # the oracle's sample, replan's and flp's
    for rel in runs:
        run = read_run((suite_run / rel).parent)
        # replan (the task restated) cannot find the lost mug
        assert run.loop and run.success is ("replan" not in rel)
    flp = [read_run((suite_run / rel).parent) for rel in runs if "flp" in rel]
    assert flp and any(r.reasoning and r.reasoning.exchanges for r in flp[0].rounds)


def test_without_kept_runs_no_sample_links_anywhere(tmp_path: Path) -> None:
    config = PromptingConfig(llm="oracle", methods=(), out_dir=tmp_path)
    record = _record(task="ol02-table1", key="oracle/x")
    page = render_page([record], summarise([record], ["oracle"]), config)
    assert "not kept" in page and not [h for h in _links(page) if not h.startswith("#")]


def test_strings_from_records_are_text(tmp_path: Path) -> None:
    config = PromptingConfig(llm=HOSTILE, methods=("flp",), out_dir=tmp_path, keep_runs=True)
    record = _record(method="flp", task=HOSTILE, goals=[HOSTILE], key=f"../../{HOSTILE}")
    page = render_page([record], summarise([record], ["flp"]), config)
    assert "<script" not in page and "<img src=x" not in page and "\x1b" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page


def test_the_suite_page_and_a_kept_run_load_clean(driver: Any, suite_run: Path) -> None:
    seen = browser.check(driver, suite_run / "index.html")
    assert seen.console == () and seen.broken == () and seen.images == 1
    run_page = next((suite_run / "runs").glob("flp*/index.html"))
    seen = browser.check(driver, run_page)
    assert seen.console == () and seen.broken == () and seen.scripts == 0
    assert "round-0" in seen.sections
    assert driver.execute_script("return !!document.getElementById('reasoning-0');")


def _record(**fields: Any) -> dict[str, Any]:
    return {
        "method": "oracle",
        "sample": 0,
        "category": "object-loss",
        "l_gt": 2,
        "success": True,
        "verdict": "success",
        "completed": True,
        "resolution_length": 2,
        "answers": 1,
        "syntax_errors": 0,
        "repairs": 0,
        "tokens": 0,
        "latency": 0.0,
        **fields,
    }
