"""The second household suite (issue #36, item 4): at least 40 tasks in the three categories,
written and frozen by a commit before any model ran on it, each marked ``measures_llm`` (the
oracle solves it and replanning alone does not: ``llmpas bench validate-data
src/llmpas/experiments/suite/household-b``, run before the commit, hours of CPU, not here). Here:
what can be checked without planning — the files load, the counts, no name or description of
the first suite reused, and the files are those frozen."""

from __future__ import annotations

import hashlib

import pytest

from llmpas.experiments.suite import SUITE_DIR, Category, load_task
from llmpas.experiments.suite.task_files import SUITE_B_DIGEST, SUITE_B_DIR, suite_digest

FILES = sorted(SUITE_B_DIR.glob("*.toml"))
PLACEHOLDER = 99  # l_gt before validation


def test_the_second_suite_has_forty_tasks_in_three_categories() -> None:
    tasks = [load_task(p) for p in FILES]
    assert len(tasks) >= 40
    for cat in Category:
        assert sum(t.category is cat for t in tasks) >= 13, cat
    assert all(t.measures_llm for t in tasks)


def test_it_shares_no_task_or_sentence_with_the_first_suite() -> None:
    first = [load_task(p) for p in sorted(SUITE_DIR.glob("*.toml"))]
    second = [load_task(p) for p in FILES]
    assert not {t.name for t in first} & {t.name for t in second}
    sentences = {
        s.strip()
        for t in first
        for s in " ".join(t.scenario.description.split()).split(".")
        if len(s.strip()) > 20
    }
    for t in second:
        for s in " ".join(t.scenario.description.split()).split("."):
            assert s.strip() not in sentences, (t.name, s)


def test_the_files_are_those_frozen() -> None:
    """Edited after its first run, the suite would no longer be the one measured: a change
    needs a new suite (and a new digest), never an edit. Until it is frozen (validated, its
    ``l_gt`` set), every task still has the placeholder ``l_gt = 99``: no model may run on it."""
    if not SUITE_B_DIGEST:
        assert all(load_task(p).l_gt == PLACEHOLDER for p in FILES)
        pytest.skip("the second suite is not frozen yet: validate-data, set l_gt, then freeze")
    assert suite_digest(SUITE_B_DIR) == SUITE_B_DIGEST
    assert len(SUITE_B_DIGEST) == len(hashlib.sha256().hexdigest())


def test_the_development_half_is_fixed_by_name_and_balanced() -> None:
    from llmpas.experiments.suite import development_half, load_suite

    tasks = load_suite(SUITE_DIR)
    dev = development_half(tasks)
    assert dev == development_half(list(reversed(tasks)))  # the order given does not matter
    for cat in Category:
        names = [t.name for t in tasks if t.category is cat]
        assert len([n for n in names if n in dev]) == (len(names) + 1) // 2
    assert 0 < len(dev) < len(tasks)


def _anomaly(path: object) -> str:
    """What a task's anomaly is, placement aside: the goal, the objects with their hidden
    states, the events (what happens to which object, not when or where to), the house's
    settings and the category."""
    import json
    import tomllib
    from pathlib import Path

    d = tomllib.loads(Path(str(path)).read_text())
    objects = sorted((o["name"], sorted(o.get("properties", []))) for o in d.get("objects", []))
    where = ("region", "x", "y", "after")
    events = sorted(
        json.dumps({k: v for k, v in e.items() if k not in where}, sort_keys=True)
        for e in d.get("events", [])
    )
    key = [d["task"]["goal"].lower(), objects, events, d.get("house", {}), d["judge"]["category"]]
    return json.dumps(key, sort_keys=True)


def test_no_task_is_a_first_suite_task_moved_elsewhere() -> None:
    """Issue #43 item 1: a task of the second suite differs from every task of the first in
    what the anomaly is (goal, objects and their states, events, house), not only in where
    things stand or what the description says."""
    first = {_anomaly(p): p.stem for p in sorted(SUITE_DIR.glob("*.toml"))}
    same = {p.stem: first[_anomaly(p)] for p in FILES if _anomaly(p) in first}
    assert not same
    mine = [_anomaly(p) for p in FILES]
    assert len(set(mine)) == len(mine)
