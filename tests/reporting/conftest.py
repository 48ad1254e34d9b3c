"""Run folders for the report tests: the README's main job (PyBullet, oracle) through the real
command line, and a household loop whose LLM answers with hostile text."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from llmpas.reasoning.llm import Request, Response
from llmpas.reporting import browser

from ..system_packages import skip_without_chromium

HOSTILE = (
    "<script>alert(1)</script> <img src=x onerror=alert(2)> "
    "\x1b[31mred\x1b[0m \x1b]0;title\x07 \ud800 \u202eevil\u202c & \"quoted\" 'single'"
)


class HostileLLM:
    """Answers every request with markup, terminal escapes and a lone surrogate."""

    name = "hostile"

    def complete(self, request: Request) -> Response:
        return Response(f"{HOSTILE}\nGoals: (and {HOSTILE})", model=f"hostile{HOSTILE[:20]}")


@pytest.fixture(scope="session")
def main_job(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``llmpas run object-loss --llm oracle --out X`` (a few seconds)."""
    pytest.importorskip("pybullet")
    from llmpas.cli import main

    out = tmp_path_factory.mktemp("main-job") / "object-loss"
    assert main(["run", "object-loss", "--llm", "oracle", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="session")
def hostile_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A household closed loop whose LLM is :class:`HostileLLM`, saved and reported."""
    from llmpas.experiments.worlds import run_loop
    from llmpas.reporting import build_report

    out = tmp_path_factory.mktemp("hostile") / "run"
    result = run_loop("object-loss-table", HostileLLM())
    assert not result.success and any(r.proposal for r in result.rounds)
    result.save(out / "loop.json")  # (loop.md is another writer's; its surrogates are not ours)
    build_report(out, {"llm": HOSTILE, "world": "household", "method": "flp"})
    return out


@pytest.fixture(scope="session")
def driver() -> Iterator[Any]:
    """Headless Chromium: a failure in CI when it is missing, else a skip."""
    skip_without_chromium()
    pytest.importorskip("selenium")
    with browser.chromium() as d:
        yield d


@pytest.fixture(scope="session")
def suite_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``llmpas bench prompting --llm oracle --methods flp --keep-runs`` on one task."""
    from llmpas.cli import main

    out = tmp_path_factory.mktemp("prompting") / "out"
    argv = ["bench", "prompting", "--llm", "oracle", "--methods", "flp", "--tasks", "ol02-table1"]
    assert main([*argv, "--samples", "1", "--keep-runs", "--out", str(out)]) == 0
    return out
