"""Which of the LLM's goals made the difference, read back from a run folder (hand-written
records: the reader, not a run, is under test)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from llmpas.reporting.difference import difference
from llmpas.reporting.page import render
from llmpas.reporting.run_folder import read_run


def _round(goal: str, status: str, goals: list[str] | None = None, ok: bool = True) -> dict:
    out: dict[str, Any] = {"goal": goal, "status": status, "plan": {}, "episode": None}
    if goals is not None:
        out["reasoning"] = {
            "method": "flp",
            "status": "ok" if ok else "unreachable",
            "goals": goals if ok else [],
            "errors": [],
            "exchanges": [],
        }
    return out


def _folder(tmp: Path, success: bool, rounds: list[dict], baseline: dict | None) -> Path:
    (tmp / "loop.json").write_text(
        json.dumps({"scenario": "s", "success": success, "message": "m", "rounds": rounds})
    )
    if baseline is not None:
        (tmp / "replan-only").mkdir()
        (tmp / "replan-only" / "loop.json").write_text(json.dumps(baseline))
        (tmp / "about.json").write_text(json.dumps({"baseline": "replan-only"}))
    return tmp


def test_the_goals_reached_last_before_the_task_made_the_difference(tmp_path: Path) -> None:
    rounds = [
        _round("(and (on cube bowl))", "anomaly", ["(scanned table2)"]),
        _round("(and (scanned table2))", "success"),
        _round("(and (on cube bowl))", "no-plan", ["(scanned table3)"]),
        _round("(and (scanned table3))", "success"),
        _round("(and (on cube bowl))", "success"),
    ]
    base = {"success": False, "message": "no usable goals", "rounds": [{}]}
    run = read_run(_folder(tmp_path, True, rounds, base))
    d = difference(run)
    assert [o.fate for o in d.outcomes] == ["reached", "reached"]
    assert d.decisive == ("(scanned table3)",)
    assert "did not finish: no usable goals" in d.verdict
    assert "(scanned table3) were reached in round 3" in d.verdict
    page = render(run)
    assert 'id="difference"' in page and 'href="replan-only/index.html"' in page


def test_when_replanning_alone_also_finishes_the_page_says_so(tmp_path: Path) -> None:
    rounds = [
        _round("(and (on cube bowl))", "anomaly", ["(on cube bowl)"]),
        _round("(and (on cube bowl))", "success"),
    ]
    run = read_run(_folder(tmp_path, True, rounds, {"success": True, "rounds": [{}, {}]}))
    assert "this run does not need its LLM" in difference(run).verdict


def test_a_rejected_answer_and_a_missing_baseline(tmp_path: Path) -> None:
    rounds = [_round("(and (on cube bowl))", "anomaly", ["(on cube bowl)"], ok=False)]
    d = difference(read_run(_folder(tmp_path, False, rounds, None)))
    assert [o.fate for o in d.outcomes] == ["rejected"] and d.baseline is None
    assert d.decisive == () and "did not lead" in d.verdict
