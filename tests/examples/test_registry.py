"""The example registry and the package data behind it."""

from __future__ import annotations

from importlib.resources import as_file, files

import pytest

from llmpas.examples import EXAMPLES, Example, get_example
from llmpas.language.domain import read_domain
from llmpas.language.problem import Problem
from llmpas.language.streams import read_streams

PACKAGES = {
    "blocksworld": ("domain.pddl", "problem.pddl"),
    "tamp2d": ("domain.pddl", "stream.pddl"),
    "mobile": ("domain.pddl", "stream.pddl"),
}


def test_registry_names() -> None:
    assert set(EXAMPLES) == {"blocksworld", "tamp2d", "mobile"}
    for name, ex in EXAMPLES.items():
        assert isinstance(ex, Example)
        assert ex.name == name
        assert ex.description
        assert ex.default_size >= 1
        assert ex.sizes == tuple(sorted(ex.sizes)) and len(ex.sizes) >= 3


def test_registry_is_read_only() -> None:
    with pytest.raises(TypeError):
        EXAMPLES["x"] = EXAMPLES["tamp2d"]  # type: ignore[index]


def test_get_example_is_case_insensitive() -> None:
    assert get_example("TAMP2D") is EXAMPLES["tamp2d"]


def test_unknown_example_lists_known_names() -> None:
    with pytest.raises(KeyError, match="blocksworld, mobile, tamp2d"):
        get_example("sokoban")


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_make_problem_at_default_and_smallest_sizes(name: str) -> None:
    ex = get_example(name)
    for size in (ex.default_size, ex.sizes[0]):
        p = ex.make_problem(size, 0)
        assert isinstance(p, Problem)


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_pddl_files_are_package_data(package: str) -> None:
    root = files(f"llmpas.examples.{package}")
    domain, other = PACKAGES[package]
    with as_file(root.joinpath(domain)) as path:
        assert read_domain(path).actions
    with as_file(root.joinpath(other)) as path:
        assert path.is_file()
        if other == "stream.pddl":
            assert read_streams(path).streams
