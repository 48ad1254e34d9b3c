"""Opt-in live run of the offline default model (Qwen2.5-Coder-1.5B via llama-cpp-python):
``pytest -m slow tests/test_live_model.py``. Skipped when llama-cpp-python or the model is not
installed (``pip install -e ".[llm]" && llmpas model install``). Greedy text can differ between
builds and CPUs, so the test asserts what the system guarantees (grammar-bound answers always
parse; the loop ends with a clear outcome) and that the dirty apple is recovered."""

from __future__ import annotations

import importlib.util
import logging
from collections.abc import Iterator

import py_trees
import pytest

from llmpas.experiments.worlds import run_loop
from llmpas.reasoning.goal_reading import GoalStatus
from llmpas.reasoning.models import DEFAULT_MODEL, model_path

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        importlib.util.find_spec("llama_cpp") is None, reason="llama-cpp-python not installed"
    ),
    pytest.mark.skipif(not model_path(DEFAULT_MODEL).is_file(), reason="model not installed"),
]
log = logging.getLogger(__name__)
SYNTAX_ERRORS = {
    GoalStatus.SYNTAX,
    GoalStatus.UNKNOWN_PREDICATE,
    GoalStatus.ARITY,
    GoalStatus.UNKNOWN_OBJECT,
    GoalStatus.WRONG_KIND,
    GoalStatus.EMPTY,
}


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


@pytest.fixture(scope="module")
def model() -> object:
    from llmpas.reasoning.backends.llamacpp import LlamaCppBackend

    return LlamaCppBackend(model_path(DEFAULT_MODEL))


def test_live_offline_model_recovers_the_dirty_apple(model: object) -> None:
    result = run_loop("state-change-apple", model)  # type: ignore[arg-type]
    proposals = [r.proposal for r in result.rounds if r.proposal]
    assert proposals, "the anomaly reached the model"
    for p in proposals:  # the grammar makes syntax errors impossible
        assert p.parse.status not in SYNTAX_ERRORS, p.parse.errors
        log.info("goals %s in %.1f s", [str(g) for g in p.goals], p.latency)
    assert result.success, result.message
