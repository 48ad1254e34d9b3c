"""Locating and reading the PDDL files shipped with the examples (package data)."""

from __future__ import annotations

from importlib.resources import files

from llmpas.language.domain import Domain, parse_domain
from llmpas.language.streams import StreamSpec, parse_streams


def read_text(package: str, name: str) -> str:
    """The text of ``name`` inside the example package ``package``."""
    return files(package).joinpath(name).read_text(encoding="utf-8")


def load_domain(package: str, name: str = "domain.pddl") -> Domain:
    return parse_domain(read_text(package, name), _label(package, name))


def load_streams(package: str, name: str = "stream.pddl") -> StreamSpec:
    return parse_streams(read_text(package, name), _label(package, name))


def _label(package: str, name: str) -> str:
    return f"{package.rsplit('.', 1)[-1]}/{name}"
