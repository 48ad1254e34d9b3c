"""The kitchen domain every manipulation world here plans over: ``domain.pddl`` (pick, place,
scan, open/close, clean/cook/heat/cool, base motion) and ``stream.pddl`` (its samplers and
tests). Worlds differ only in their stream implementations, scenes and robots."""

from __future__ import annotations

from functools import cache
from importlib import resources

from llmpas.language.domain import Domain, parse_domain
from llmpas.language.streams import StreamSpec, parse_streams


@cache
def _text(name: str) -> str:
    return resources.files(__name__).joinpath(name).read_text(encoding="utf-8")


def load_domain() -> Domain:
    return parse_domain(_text("domain.pddl"), "kitchen/domain.pddl")


def load_streams() -> StreamSpec:
    return parse_streams(_text("stream.pddl"), "kitchen/stream.pddl")


__all__ = ["load_domain", "load_streams"]
