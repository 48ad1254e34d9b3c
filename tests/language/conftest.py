"""Fixtures for the problem-language tests: the wild domain, stream file and problem on disk."""

from __future__ import annotations

from pathlib import Path

import pytest

from llmpas.language.domain import Domain, parse_domain
from llmpas.language.streams import StreamSpec, parse_streams

from .texts import STREAM_FILE, WILD_DOMAIN, WILD_PROBLEM


@pytest.fixture
def wild_domain() -> Domain:
    return parse_domain(WILD_DOMAIN, "wild/domain.pddl")


@pytest.fixture
def wild_streams() -> StreamSpec:
    return parse_streams(STREAM_FILE, "wild/stream.pddl")


@pytest.fixture
def wild_impls() -> dict[str, object]:
    """Python implementations of every stream of STREAM_FILE, keyed as users write them."""

    def find_spot(obj, surface):
        for i in range(3):
            yield (f"{obj}-spot{i}",)

    def reach(arm, obj, spot, hold, fluents=()):
        return ("base-x", "path-x")

    def spots_apart(o1, s1, o2, s2):
        return s1 != s2

    def travel_cost(path):
        return 2.0

    return {
        "find-spot": find_spot,
        "reach": reach,
        "spots-apart": spots_apart,
        "TravelCost": travel_cost,
    }


@pytest.fixture
def wild_files(tmp_path: Path) -> dict[str, Path]:
    files = {
        "domain": tmp_path / "domain.pddl",
        "stream": tmp_path / "stream.pddl",
        "problem": tmp_path / "problem.pddl",
    }
    files["domain"].write_text(WILD_DOMAIN, encoding="utf-8")
    files["stream"].write_text(STREAM_FILE, encoding="utf-8")
    files["problem"].write_text(WILD_PROBLEM, encoding="utf-8")
    return files
