"""Markdown / HTML episode reports and saving an episode folder."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec
from llmpas.execution.executor import Episode, ExecStatus, ExecutorConfig, execute
from llmpas.execution.export import load_in_btcpp
from llmpas.execution.report import episode_html, episode_markdown, save_episode
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom

from .test_export import place_spec
from .toy import ToyWorld, pick_spec


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def run(world: ToyWorld, *specs: SubtreeSpec, max_ticks: int = 2000) -> Episode:
    ctx = Context(
        world, world, Belief([Atom("at", ("robot", "home"))], {}), np.random.default_rng(0)
    )
    return execute(list(specs), ctx, ExecutorConfig(max_ticks=max_ticks))


@pytest.fixture
def success() -> Episode:
    ep = run(ToyWorld("t1b"), pick_spec(), place_spec())
    assert ep.status is ExecStatus.SUCCESS
    return ep


@pytest.fixture
def anomaly() -> Episode:
    ep = run(ToyWorld("t2"), pick_spec(), place_spec())
    assert ep.status is ExecStatus.ANOMALY
    return ep


def nasty_spec() -> SubtreeSpec:
    """Fails with a reason full of markup characters."""
    never = Constraint(
        "Seen",
        lambda v, c: "<b>cube</b> & | not `seen`",
        lambda v: Atom("seen", ("<cube>",)),
        needs=("where",),
    )
    sub = SubAction("look <around>", lambda v, c: c.robot.move_arm(None), constraints=(never,))
    dims = (Dimension("where", lambda v: ["a<1", "b&2"]),)
    return SubtreeSpec("look <b>", (0,), "look", ("<cube>",), {}, dims, (sub,))


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.text: list[str] = []
        self.tags: list[str] = []

    def handle_starttag(self, tag: str, attrs: Any) -> None:
        self.tags.append(tag)

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def parse_html(page: str) -> _Text:
    p = _Text()
    p.feed(page)
    p.close()
    return p


def md_cells(line: str) -> list[str]:
    """Cells of a Markdown table row (escaped pipes do not split)."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]


def md_row(md: str, first: str) -> list[str]:
    return next(md_cells(x) for x in md.splitlines() if x.startswith(f"| {first} |"))


# ---------------------------------------------------------------------------------- markdown
def test_markdown_of_a_success(success: Episode) -> None:
    md = episode_markdown(success, title="Pick and place")
    assert md.startswith("# Pick and place\n") and "**Status: success**" in md
    assert "## Anomaly" not in md
    assert md_row(md, "subtrees") == ["subtrees", "2"]
    assert md_row(md, "retries (backtracks)") == ["retries (backtracks)", str(success.retries)]
    assert md_row(md, "completed plan steps") == ["completed plan steps", "0, 1, 2"]
    assert md_row(md, "ticks") == ["ticks", str(success.ticks)]
    timeline = [x for x in md.splitlines() if re.match(r"\| \d+ \| \d+\.\d{3} \|", x)]
    assert len(timeline) == len(success.events)
    assert md_cells(timeline[-1])[2:4] == ["`release`", "success"]
    assert "`(at robot home)`" in md.split("## Final believed state")[1]


def test_markdown_of_an_anomaly(anomaly: Episode) -> None:
    md = episode_markdown(anomaly)
    report = anomaly.anomaly
    assert report is not None
    assert "**Status: anomaly**" in md and "## Anomaly" in md
    assert md_row(md, "constraint") == ["constraint", "`(on cube table1)`"]
    assert md_row(md, "sub-action") == ["sub-action", "`locate`"]
    assert md_row(md, "`base`") == ["`base`", "`'q1', 'q2'`", "2 (2 distinct)"]
    region = md_row(md, "`region`")
    assert region[1] == "`'t1a', 't1b', 't1c', 't1a', 't1b', 't1c'`" and region[2].startswith("6")
    assert md_row(md, "`Detected`") == ["`Detected`", "6"]
    assert "- looked at t1c: saw nothing" in md
    assert "> While executing move-and-pick(cube)" in md
    assert "cube not detected in t1a" in md.split("## Timeline")[1]
    assert "`release`" not in md  # the place subtree never ran


def test_markdown_escapes_table_breaking_text() -> None:
    ep = run(ToyWorld("t1a"), nasty_spec())
    md = episode_markdown(ep)
    assert md_row(md, "reason") == ["reason", r"\<b\>cube\</b\> \& \| not \`seen\`"]
    assert md_row(md, "constraint") == ["constraint", "`(seen <cube>)`"]


def test_long_timelines_are_cut_with_a_note(anomaly: Episode) -> None:
    md = episode_markdown(anomaly, max_events=3)
    assert len([x for x in md.splitlines() if re.match(r"\| \d+ \| \d", x)]) == 3
    assert f"{len(anomaly.events) - 3} later events not shown" in md


def test_budget_episode_shows_its_message() -> None:
    ep = run(ToyWorld("t2"), pick_spec(), max_ticks=2)
    assert ep.status is ExecStatus.BUDGET
    md = episode_markdown(ep)
    assert "**Status: budget-exhausted**" in md and "max\\_ticks=2" in md
    assert "budget-exhausted" in episode_html(ep)


# ---------------------------------------------------------------------------------- HTML
def test_html_is_self_contained_and_complete(anomaly: Episode) -> None:
    page = episode_html(anomaly, title="Cube <missing>")
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"(src|href)=|<script|<link|@import|url\(", page)
    parsed = parse_html(page)
    text = "".join(parsed.text)
    assert "Cube <missing>" in text and "<missing>" not in page
    assert "(on cube table1)" in text and "'t1a', 't1b', 't1c', 't1a', 't1b', 't1c'" in text
    assert parsed.tags.count("table") == 6  # summary x2, fields, explored, failures, timeline
    rows = page.split("<h2>Timeline</h2>")[1].count("<tr class=")
    assert rows == len(anomaly.events)
    assert "cube not detected in t1b" in text and 'class="ev-backtrack"' in page


def test_html_escapes_markup_from_the_world() -> None:
    ep = run(ToyWorld("t1a"), nasty_spec())
    page = episode_html(ep)
    parsed = parse_html(page)
    assert "b" not in parsed.tags  # no tag was injected
    text = "".join(parsed.text)
    assert "<b>cube</b> & | not `seen`" in text and "(seen <cube>)" in text
    assert "where=a<1" in text and "&lt;b&gt;cube&lt;/b&gt; &amp;" in page


def test_success_html_has_no_anomaly_section(success: Episode) -> None:
    text = "".join(parse_html(episode_html(success)).text)
    assert "Anomaly" not in text and "(at robot home)" in text and "success" in text


# ---------------------------------------------------------------------------------- files
def test_save_episode_writes_every_file(anomaly: Episode, tmp_path: Path) -> None:
    folder = tmp_path / "runs" / "ep1"
    paths = save_episode(anomaly, folder, specs=[pick_spec(), place_spec()])
    assert [p.name for p in paths] == [
        "episode.json",
        "report.md",
        "report.html",
        "plan.xml",
        "move_and_pick_cube.xml",
        "place_cube_table2.xml",
    ]
    assert sorted(p.name for p in folder.iterdir()) == sorted(p.name for p in paths)
    assert json.loads((folder / "episode.json").read_text()) == json.loads(
        json.dumps(anomaly.to_json())
    )
    assert (folder / "report.md").read_text() == episode_markdown(anomaly)
    assert (folder / "report.html").read_text() == episode_html(anomaly)
    for p in paths[3:]:
        load_in_btcpp(p.read_text())
    assert all(p.stat().st_mode & 0o044 for p in paths)  # readable by others too


def test_save_episode_without_specs(success: Episode, tmp_path: Path) -> None:
    paths = save_episode(success, tmp_path)
    assert [p.name for p in paths] == ["episode.json", "report.md", "report.html"]
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.parametrize("failing", ["episode.json", "report.html", "plan.xml"])
def test_failed_save_leaves_no_partial_files(
    failing: str, success: Episode, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = os.replace

    def replace(src: Any, dst: Any) -> None:
        if Path(dst).name == failing:
            raise OSError("disk full")
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    folder = tmp_path / "out"
    with pytest.raises(OSError, match="disk full"):
        save_episode(success, folder, specs=[pick_spec()])
    order = ["episode.json", "report.md", "report.html", "plan.xml"]
    assert sorted(p.name for p in folder.iterdir()) == sorted(order[: order.index(failing)])
