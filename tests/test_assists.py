"""The loop's assists as switches: the paper's protocol reads the LLM's goals and checks their
syntax only; each assist, switched on alone, does what it says. Test doubles know nothing."""

from __future__ import annotations

import pytest

from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.reasoning.assists import PROTOCOLS, Assists, ablation, parse_assists
from llmpas.reasoning.methods import MethodConfig
from tests.test_system import Scripted, clean_blackboard  # noqa: F401 (autouse fixture)


def _config(assists: Assists, method: str = "one-step", rounds: int = 3) -> LoopConfig:
    return LoopConfig(method=MethodConfig(method), max_rounds=rounds, assists=assists)


def test_assists_parse_by_protocol_and_by_name() -> None:
    assert parse_assists("paper") == Assists.none() and parse_assists("assisted") == Assists()
    both = parse_assists("search-rewrite+repair")
    assert both.on == ("search_rewrite", "repair") and both.label == "search_rewrite+repair"
    assert PROTOCOLS["paper"].label == "paper"
    with pytest.raises(ValueError, match="unknown assist 'telepathy'"):
        parse_assists("telepathy")
    variants = ablation()
    assert variants[0] == Assists.none() and variants[-1] == Assists()
    assert len(variants) == len(Assists.names()) + 2


def test_the_papers_protocol_plans_an_answer_as_given() -> None:
    # (on cube table2_right) for the lost cube: the assisted loop reads it as the search it
    # states and finds the cube; as given, no plan can put a lost cube anywhere
    answer = "Goals: (and (on cube table2_right))"
    assisted = run_loop("object-loss-table", Scripted(answer), _config(Assists()))
    assert assisted.success, assisted.message
    llm = Scripted(answer)
    paper = run_loop("object-loss-table", llm, _config(Assists.none()))
    assert not paper.success
    proposal = next(r.proposal for r in paper.rounds if r.proposal)
    assert [str(g) for g in proposal.goals] == ["(on cube table2_right)"]
    assert "no plan" in paper.message
    assert len(llm.requests) == 1  # one answer, no repair
    # the search rewrite alone is what makes the difference on this answer
    alone = run_loop(
        "object-loss-table", Scripted(answer), _config(Assists.only(["search_rewrite"]))
    )
    assert alone.success, alone.message


def test_the_papers_protocol_lists_no_unsearched_places_and_prunes_nothing() -> None:
    llm = Scripted("Goals: (and (scanned table1_right))")  # searched in vain already
    run_loop("object-loss-table", llm, _config(Assists.none(), rounds=1))
    prompt = llm.requests[0].messages[-1].content
    assert "cube was not found on" in prompt  # what the robot saw stays in the prompt
    assert "places not searched yet" not in prompt
    assert "table1_right" in (llm.requests[0].grammar or "")
    listed = Scripted("Goals: (and (scanned table1_right))")
    run_loop("object-loss-table", listed, _config(Assists.only(["unsearched_list"]), rounds=1))
    assert "places not searched yet for cube" in listed.requests[0].messages[-1].content


def test_validation_alone_rejects_a_repeated_search_without_repairing_it() -> None:
    llm = Scripted("Goals: (and (scanned table1_right))")
    result = run_loop("object-loss-table", llm, _config(Assists.only(["validation"])))
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert proposal.parse.status.value == "repeated" and proposal.repairs == 0
    assert len(llm.requests) == 1
