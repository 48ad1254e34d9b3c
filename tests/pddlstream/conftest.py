"""The test scripts import ``pddlstream...``: the tests load them with this API's modules."""

from __future__ import annotations

import importlib.util
import sys
import types
from collections.abc import Iterator
from pathlib import Path

import pytest

from llmpas.pddlstream.compat import build_modules
from llmpas.pddlstream.solving import Attempt, SolveContext

SCRIPTS = Path(__file__).parent / "scripts"


class Loaded:
    """A test script loaded with this API, and the attempts its solves made."""

    def __init__(self, module: types.ModuleType, attempts: list[Attempt]) -> None:
        self.module = module
        self.attempts = attempts


@pytest.fixture
def load_script() -> Iterator:
    added: list[str] = []

    def load(name: str) -> Loaded:
        attempts: list[Attempt] = []
        modules = build_modules(SolveContext(on_attempt=attempts.append))
        for k, m in modules.items():
            sys.modules[k] = m
            added.append(k)
        spec = importlib.util.spec_from_file_location(f"pds_script_{name}", SCRIPTS / f"{name}.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module  # dataclasses look their module up
        added.append(spec.name)
        spec.loader.exec_module(module)
        return Loaded(module, attempts)

    yield load
    for k in added:
        sys.modules.pop(k, None)
