"""Prompting methods as registry entries, and the reasoning options for small models:
self-consistency with the validator as verifier, multi-place goals, a structured first look.
The LLMs here are test doubles that know nothing (fixed answers in order)."""

from __future__ import annotations

from importlib import resources

import pytest

from llmpas.language.logic import Atom
from llmpas.reasoning.goal_reading import GoalParse, GoalStatus, Vocabulary
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.methods import (
    METHODS,
    PAPER_METHODS,
    REGISTRY,
    Method,
    MethodConfig,
    Situation,
    propose,
    rejected,
)

VOCAB = Vocabulary.of({"scanned": (("table1", "table2", "table3"),)})
SITUATION = Situation("the cube was not found on table1", "- look", "- scanned", "", "task")


class Answers:
    """Fixed answers in order (the last one repeated); records the requests."""

    name = "answers"

    def __init__(self, *answers: str) -> None:
        self.answers = answers
        self.requests: list[Request] = []

    def complete(self, request: Request) -> Response:
        self.requests.append(request)
        k = min(len(self.requests), len(self.answers)) - 1
        return Response(self.answers[k], model="answers")


def test_every_registered_method_has_its_templates() -> None:
    folder = resources.files("llmpas.reasoning").joinpath("templates")
    for m in REGISTRY.values():
        assert folder.joinpath(f"{m.template}.txt").is_file(), m.name
        if m.first_look:
            assert folder.joinpath(f"{m.first_look}.txt").is_file(), m.name
    assert set(PAPER_METHODS) <= set(METHODS)
    assert {"flp-multi", "flp-hypotheses"} <= set(METHODS)


def test_a_method_entry_is_validated() -> None:
    with pytest.raises(ValueError, match="reader"):
        Method("mine", "flp_step2", reader="telepathy")
    with pytest.raises(ValueError, match="name"):
        Method("Mine!", "flp_step2")
    with pytest.raises(ValueError, match="votes"):
        MethodConfig(votes=0)


def test_the_structured_first_look_asks_for_hypotheses_and_shows_them_in_step_two() -> None:
    llm = Answers(
        "1. Cause: moved. Check or fix: (scanned table2). Next: look.", "(scanned table2)"
    )
    p = propose(SITUATION, llm, VOCAB, MethodConfig("flp-hypotheses", decoding="none"))
    assert p.ok and [str(g) for g in p.goals] == ["(scanned table2)"]
    step1, step2 = (r.messages[-1].content for r in llm.requests)
    assert "hypotheses" in step1 and llm.requests[0].tag == "first-look"
    assert "Cause: moved" in step2  # the hypotheses are step 2's first look


def test_the_multi_place_method_asks_for_every_possibility_in_one_answer() -> None:
    llm = Answers("look around", "Goals: (and (scanned table2) (scanned table3))")
    p = propose(SITUATION, llm, VOCAB, MethodConfig("flp-multi", decoding="none"))
    assert len(p.goals) == 2 and len(llm.requests) == 2
    assert "cover every plausible one" in llm.requests[1].messages[-1].content


def _only_table3(parse: GoalParse) -> GoalParse:
    """A verifier that accepts only (scanned table3) (as the planner-backed check would a
    reachable goal)."""
    if parse.goals == (Atom("scanned", ("table3",)),):
        return parse
    return rejected(parse, GoalStatus.UNREACHABLE, ["unreachable"], parse.goals)


def test_self_consistency_takes_the_valid_answer_most_samples_agree_on() -> None:
    llm = Answers(
        "Goals: (and (scanned table2))",  # the greedy answer: rejected by the check
        "Goals: (and (scanned table3))",
        "Goals: (and (scanned table2))",
        "Goals: (and (scanned table3))",
    )
    config = MethodConfig("one-step", decoding="none", votes=4, repairs=0)
    p = propose(SITUATION, llm, VOCAB, config, check=_only_table3)
    assert p.ok and [str(g) for g in p.goals] == ["(scanned table3)"]
    assert [r.tag for r in llm.requests] == ["goals", "vote-1", "vote-2", "vote-3"]
    assert all(r.temperature == config.vote_temperature for r in llm.requests[1:])
    assert len({r.seed for r in llm.requests}) == 4  # each sample its own seed
    assert any("2 of 4 answers valid" in n for n in p.parse.notes)
    # without votes the same model's first answer is rejected and nothing repairs it
    single = propose(
        SITUATION,
        Answers(*llm.answers),
        VOCAB,
        MethodConfig("one-step", decoding="none", repairs=0),
        check=_only_table3,
    )
    assert not single.ok


def test_self_consistency_with_no_valid_answer_goes_on_to_repair() -> None:
    llm = Answers(
        "Goals: (and (scanned table2))",
        "Goals: (and (scanned table1))",
        "Goals: (and (scanned table3))",
    )
    config = MethodConfig("one-step", decoding="none", votes=2, repairs=1)
    p = propose(SITUATION, llm, VOCAB, config, check=_only_table3)
    assert p.ok and p.repairs == 1
    assert [r.tag for r in llm.requests] == ["goals", "vote-1", "repair-1"]


def test_without_pruning_rejected_literals_stay_in_the_grammar() -> None:
    llm = Answers("Goals: (and (scanned table2))")
    config = MethodConfig("one-step", repairs=1)
    propose(SITUATION, llm, VOCAB, config, check=_only_table3, prune=False)
    assert llm.requests[0].grammar == llm.requests[1].grammar
    llm = Answers("Goals: (and (scanned table2))")
    propose(SITUATION, llm, VOCAB, config, check=_only_table3, prune=True)
    assert llm.requests[0].grammar != llm.requests[1].grammar
