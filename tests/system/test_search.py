"""The search memory (:class:`llmpas.system.search_memory.SearchMemory`) on a tiny in-memory search
model: what was searched for a lost object, what is left, and what the prompt, the grammar and
the validator read of it."""

from __future__ import annotations

from llmpas.language.logic import And, Atom
from llmpas.worlds.api import SearchModel
from tests.system.tiny import Facts, Model, atom, failed_look, memory


def test_the_tiny_model_is_a_search_model() -> None:
    assert isinstance(Model(Facts()), SearchModel)


def test_a_failed_detection_marks_the_places_it_looked_at_searched() -> None:
    m = memory(Facts())
    m.remember(failed_look("cup", ("t1", "t2")))
    assert m.searching() == {"cup": {"t1", "t2"}}
    assert m.left({"t1", "t2"}) == ["t3"]
    assert m.history() == [
        "- cup was not found on t1, t2",
        "- places not searched yet for cup: t3",
    ]
    assert set(m.exhausted()) == {
        atom("(scanned t1)"),
        atom("(on cup t1)"),
        atom("(scanned t2)"),
        atom("(on cup t2)"),
    }


def test_another_failure_is_no_search() -> None:
    m = memory(Facts())
    m.remember(failed_look("cup", ("t1",), name="Reached"))
    assert m.searching() == {} and m.history() == [] and m.exhausted() == ()


def test_without_the_assist_the_places_left_are_not_listed() -> None:
    m = memory(Facts(), list_unsearched=False)
    m.remember(failed_look("cup", ("t1",)))
    assert m.history() == ["- cup was not found on t1"]
    assert m.not_searched({"t1"}) == ""
    listed = memory(Facts())
    assert listed.not_searched({"t1"}) == " (not searched yet: t2, t3)"


def test_a_search_goal_reached_while_the_object_is_lost_searches_that_place() -> None:
    m = memory(Facts())
    m.remember(failed_look("cup", ("t1",)))
    m.searched_in(And((atom("(scanned t2)"), atom("(clean plate)"))))
    assert m.searching() == {"cup": {"t1", "t2"}}


def test_a_place_whose_belief_changes_is_worth_another_look() -> None:
    facts = Facts()
    m = memory(facts)
    m.remember(failed_look("cup", ("t1", "t2")))
    facts.facts.add(atom("(on plate t1)"))  # something was put on t1 since
    assert m.searching() == {"cup": {"t2"}}


def test_an_object_found_has_no_exhausted_searches() -> None:
    facts = Facts()
    m = memory(facts)
    m.remember(failed_look("cup", ("t1",)))
    facts.facts.add(atom("(on cup t3)"))
    assert m.exhausted() == ()


def test_places_the_belief_says_were_scanned_count_for_a_lost_task_object() -> None:
    facts = Facts({atom("(scanned t3)")})
    m = memory(facts, task=And((atom("(on cup t1)"),)))
    assert m.searching() == {"cup": {"t3"}}
    facts.facts.add(atom("(holding cup)"))  # no longer lost
    assert m.searching() == {}


def test_a_location_of_a_lost_object_reads_as_a_search() -> None:
    facts = Facts()
    m = memory(facts)
    assert m.as_search(atom("(on cup t2)")) == atom("(scanned t2)")
    assert m.as_search(atom("(on cup sink)")) == atom("(on cup sink)")  # not a place to search
    assert m.as_search(atom("(clean cup)")) == atom("(clean cup)")
    facts.facts.add(atom("(on cup t1)"))
    assert m.as_search(atom("(on cup t2)")) == atom("(on cup t2)")  # not lost: a real goal
    assert m.look("t1") == Atom("scanned", ("t1",)) and m.is_look(m.look("t1"))
