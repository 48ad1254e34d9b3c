"""The closed loop: plan -> execute -> reason -> replan. The oracle (an upper bound that reads
the simulator's truth, labelled as such) recovers every anomaly type; scripted LLMs exercise the
deadlock guard and garbage answers. No test needs a real model or a key."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import py_trees
import pytest

from llmpas.experiments.worlds import LoopConfig, run_loop
from llmpas.reasoning.llm import Request, Response
from llmpas.reasoning.methods import MethodConfig
from llmpas.reasoning.truth_oracle import ORACLE  # the upper bound


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


class Scripted:
    """A test double that always gives the same answer (not an oracle: it knows nothing)."""

    name = "scripted"

    def __init__(self, answer: str) -> None:
        self.answer = answer
        self.requests: list[Request] = []

    def complete(self, request: Request) -> Response:
        self.requests.append(request)
        return Response(self.answer, model="scripted")


@pytest.mark.parametrize(
    ("scenario", "where"),
    [
        ("object-loss-table", "bowl"),
        ("object-loss-drawer", "bowl"),
        ("object-loss-basket", "bowl"),
        ("action-blocking-bowl", "bowl"),
    ],
)
def test_oracle_recovers_object_loss_and_blocking(scenario: str, where: str) -> None:
    result = run_loop(scenario, ORACLE)
    assert result.success, result.message
    assert any(r.proposal is not None for r in result.rounds)  # the LLM was needed
    assert len(result.rounds) >= 2


def test_oracle_recovers_the_blocked_microwave() -> None:
    result = run_loop("action-blocking-microwave", ORACLE)
    assert result.success, result.message
    first = result.rounds[0]
    assert first.episode is not None and first.episode.anomaly is not None
    assert str(first.episode.anomaly.constraint) == "(not (full microwave))"


def test_oracle_recovers_the_dirty_apple_and_the_truth_agrees() -> None:
    result = run_loop("state-change-apple", ORACLE)
    assert result.success, result.message
    goals = [str(g) for r in result.rounds if r.proposal for g in r.proposal.goals]
    assert goals == ["(cleaned apple)"]


def test_deadlock_guard_stops_a_repeated_exhausted_search() -> None:
    llm = Scripted("Goals: (and (scanned table1_right))")  # where the cube was not found
    result = run_loop("object-loss-table", llm, LoopConfig(max_rounds=3))
    assert not result.success
    proposal = result.rounds[-1].proposal
    assert proposal is not None and not proposal.ok
    assert proposal.parse.status.value == "repeated"
    assert any("already searched" in e for e in proposal.parse.errors)
    # bounded: step 1, step 2, and the configured repairs — then the loop stops
    assert len(llm.requests) == 2 + LoopConfig().method.repairs


def test_a_negative_round_bound_is_refused_in_every_world() -> None:
    from llmpas.system import LoopSettings

    for config in (LoopConfig, LoopSettings):
        with pytest.raises(ValueError, match="max_rounds"):
            config(max_rounds=-1)


def test_garbage_answers_end_with_a_clear_message() -> None:
    llm = Scripted("import os; os.system('rm -rf /')  # run this")
    result = run_loop("object-loss-table", llm)
    assert not result.success
    assert "no usable goals" in result.message


def test_loop_record_holds_prompts_responses_and_goals(tmp_path: Path) -> None:
    result = run_loop("state-change-apple", ORACLE)
    data = json.loads(result.save(tmp_path / "loop.json").read_text())
    reasoning = [r["reasoning"] for r in data["rounds"] if "reasoning" in r]
    assert reasoning and reasoning[0]["goals"] == ["(cleaned apple)"]
    tags = [e["tag"] for e in reasoning[0]["exchanges"]]
    assert tags == ["first-look", "goals"]
    step2 = reasoning[0]["exchanges"][1]["messages"][-1][1]
    assert "First look" in step2 and "(not (dirty apple))" in step2


def test_unreachable_goals_are_dropped_when_others_can_be_planned() -> None:
    # what the offline model answered once, on the fridge (searchable since #12): a place no
    # action scans, such as the stove, is achievable by no action
    llm = Scripted("Goals: (and (scanned stove) (cleaned apple))")
    result = run_loop("state-change-apple", llm)
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert [str(g) for g in proposal.goals] == ["(cleaned apple)"]
    assert any("dropped (scanned stove)" in n for n in proposal.parse.notes)
    assert result.success, result.message


def test_only_unreachable_goals_are_sent_back_for_repair() -> None:
    llm = Scripted("Goals: (and (scanned stove))")
    result = run_loop("state-change-apple", llm)
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert proposal.parse.status.value == "unreachable" and proposal.repairs == 2
    repair_prompt = proposal.exchanges[-1].request.messages[-1].content
    assert "(scanned stove): no sequence of the robot's actions" in repair_prompt


def test_a_lost_objects_place_is_read_as_a_search_and_true_goals_are_dropped() -> None:
    # what the offline model once answered on object loss: the cube's new place as an `on` goal
    llm = Scripted("Goals: (and (on cube table2_right) (not (open drawer1)))")
    result = run_loop("object-loss-table", llm)
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert [str(g) for g in proposal.goals] == ["(scanned table2_right)"]
    notes = " ".join(proposal.parse.notes)
    assert "read (on cube table2_right) as (scanned table2_right)" in notes
    assert "dropped (not (open drawer1)): it already holds" in notes
    assert result.success, result.message


def test_goals_that_all_hold_already_are_sent_back() -> None:
    llm = Scripted("Goals: (and (not (open drawer1)))")
    result = run_loop("object-loss-table", llm)
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert proposal.parse.status.value == "already-true" and proposal.repairs == 2
    assert not result.success


def test_a_search_that_finds_nothing_goes_back_to_the_llm_with_the_place_marked() -> None:
    class Sequence:
        name = "sequence"  # test double replaying fixed answers in order (knows nothing)

        def __init__(self, answers: list[str]) -> None:
            self.answers = answers
            self.requests: list[Request] = []

        def complete(self, request: Request) -> Response:
            self.requests.append(request)
            return Response(self.answers[min(len(self.requests), len(self.answers)) - 1])

    llm = Sequence(["Goals: (and (scanned drawer1))", "Goals: (and (scanned table2_right))"])
    result = run_loop("object-loss-table", llm, LoopConfig(method=MethodConfig("one-step")))
    assert result.success, result.message
    second = llm.requests[-1].messages[-1].content
    assert "cube was not found on drawer1, table1_left, table1_right" in second
    # closed containers are places to search too (open, then look)
    assert (
        "places not searched yet for cube: table2_left, table2_right, microwave, fridge, drawer2"
        in second
    )


def test_searched_places_and_rejected_goals_are_left_out_of_the_decoding() -> None:
    from tests.reasoning.test_grammar import language, read_grammar

    llm = Scripted("Goals: (and (scanned stove))")  # unreachable: no action scans the stove
    result = run_loop("object-loss-table", llm, LoopConfig(max_rounds=1))
    assert not result.success

    def literals(grammar: str) -> str:  # the goal rules, without the free-text reasoning line
        return "\n".join(x for x in grammar.splitlines() if not x.startswith(("root", "reason")))

    first, *repairs = [read_grammar(literals(r.grammar)) for r in llm.requests if r.grammar]
    offered = language(first, ("ref", "atom"))
    # table1_right was searched during execution: neither spelling of that search is offered
    assert "(scanned table1_right)" not in offered and "(on cube table1_right)" not in offered
    assert "(scanned table2_right)" in offered and "(scanned stove)" in offered
    for grammar in repairs:  # the rejected goal cannot be repeated in a repair
        assert "(scanned stove)" not in language(grammar, ("ref", "atom"))
        assert "(scanned table2_right)" in language(grammar, ("ref", "atom"))
    assert len(repairs) == LoopConfig().method.repairs


CASSETTES = Path(__file__).parent / "data" / "cassettes" / "qwen1.5b"


@pytest.mark.parametrize(
    "scenario", ["object-loss-table", "state-change-apple", "action-blocking-microwave"]
)
def test_offline_model_recovers_from_its_recorded_answers(scenario: str) -> None:
    """Qwen2.5-Coder-1.5B (the offline default), recorded once with `llmpas run --record`:
    replaying its answers must reproduce the recovery (a missing or changed prompt fails)."""
    from llmpas.reasoning.backends.replay import ReplayBackend

    llm = ReplayBackend(CASSETTES, mode="replay")
    result = run_loop(scenario, llm)
    assert result.success, result.message
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert proposal.first_look  # the first look was asked for and answered
    assert all(e.response.model for e in proposal.exchanges)


def test_progprompt_program_recovers_the_dirty_apple() -> None:
    from llmpas.reasoning.methods import MethodConfig

    llm = Scripted("```python\ndef recover():\n    clean('apple')\n    cool('apple')\n```")
    result = run_loop("state-change-apple", llm, LoopConfig(method=MethodConfig("progprompt")))
    assert result.success, result.message
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    prompt = proposal.exchanges[0].request.messages[-1].content
    assert "def clean(obj)" in prompt and "def recover():" in prompt
    assert proposal.exchanges[0].request.grammar is None  # a program is free text


def test_inner_monologue_skill_choice_recovers_the_dirty_apple() -> None:
    from llmpas.reasoning.methods import MethodConfig

    llm = Scripted(
        'Robot thought: The apple got dirty, so I wash it.\nRobot action: clean("apple")'
    )
    config = LoopConfig(method=MethodConfig("inner-monologue"))
    result = run_loop("state-change-apple", llm, config)
    assert result.success, result.message
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert [str(g) for g in proposal.goals] == ["(cleaned apple)"]
    request = proposal.exchanges[0].request
    prompt = request.messages[-1].content
    assert "clean(obj) -> (cleaned obj)" in prompt and "Success: False." in prompt
    assert "Human: " in prompt and "Scene: " in prompt
    assert request.grammar is not None and request.grammar.startswith('root ::= "Robot thought: "')


def test_inner_monologue_rejects_an_unknown_skill_and_feeds_it_back() -> None:
    from llmpas.reasoning.methods import MethodConfig

    llm = Scripted("Robot thought: I wash it.\nRobot action: wash_everything()")
    result = run_loop("state-change-apple", llm, LoopConfig(method=MethodConfig("inner-monologue")))
    assert not result.success
    proposal = next(r.proposal for r in result.rounds if r.proposal)
    assert proposal.repairs == 2 and not proposal.ok
    assert "unknown action 'wash_everything'" in proposal.exchanges[-1].request.messages[-1].content


def test_loop_report_shows_rounds_prompts_answers_and_goals(tmp_path: Path) -> None:
    from llmpas.reasoning.backends.replay import ReplayBackend
    from llmpas.system import save_loop

    result = run_loop("state-change-apple", ReplayBackend(CASSETTES, mode="replay"))
    files = save_loop(result, tmp_path)
    names = {p.relative_to(tmp_path).as_posix() for p in files}
    assert {"loop.json", "loop.md", "round-0/report.md", "round-1/report.md"} <= names
    assert {"round-0/plan.xml", "round-1/plan.xml"} <= names  # the subtrees of every round
    text = (tmp_path / "loop.md").read_text()
    assert "**task done**" in text
    assert "(not (dirty apple))" in text  # the anomaly
    assert "#### first-look: prompt" in text and "#### goals: answer" in text
    assert "### Reasoning (flp): (cleaned apple)" in text
    assert not list(tmp_path.rglob("*.tmp"))


def test_a_task_the_anomaly_shows_done_ends_the_loop_without_asking() -> None:
    llm = Scripted("(and (cleaned apple))")  # never asked: the apple turns out cooked already
    result = run_loop("state-change-cooked", llm)
    assert result.success and "the task holds" in result.message
    assert not llm.requests and not any(r.proposal for r in result.rounds)


@pytest.mark.parametrize(
    ("scenario", "goals"),
    [
        ("object-loss-fridge", ["(scanned fridge)"]),  # a closed container: open, then look
        ("state-change-hot", ["(cleaned bread)"]),
        ("state-change-wet", ["(not (wet mug))"]),
        ("lookalike-apple", ["(scanned drawer4)"]),
    ],
)
def test_the_oracle_recovers_the_new_household_anomalies(scenario: str, goals: list[str]) -> None:
    result = run_loop(scenario, ORACLE)
    assert result.success, result.message
    assert [str(g) for r in result.rounds if r.proposal for g in r.proposal.goals] == goals


def test_a_place_searched_in_vain_is_worth_another_look_once_a_cover_is_lifted_from_it() -> None:
    from llmpas.experiments.suite import SUITE_DIR, load_task

    # the apple is hidden under the basket on table1_left: the first search there finds nothing;
    # once the basket is lifted, looking at table1_left again is not a repeated search
    task = load_task(SUITE_DIR / "ol08-basket-table1.toml")

    class Answers(Scripted):
        def complete(self, request: Request) -> Response:
            self.requests.append(request)
            asked = [r for r in self.requests if r.tag != "first-look"]
            step = ["(and (holding basket))", "(and (scanned table1_left))"][min(len(asked), 2) - 1]
            return Response(step, model="scripted")

    llm = Answers("")
    result = run_loop(task.scenario, llm)
    assert result.success, result.message
    goals = [str(g) for r in result.rounds if r.proposal for g in r.proposal.goals]
    assert goals == ["(holding basket)", "(scanned table1_left)"]
