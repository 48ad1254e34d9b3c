"""parse_goals: every accepted answer form, the extraction rule, validation, and hostile input."""

from __future__ import annotations

import json
from types import MappingProxyType

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import (
    LOOP_STATUSES,
    MAX_CHARS,
    MAX_ERRORS,
    GoalParse,
    GoalStatus,
    Literal,
    Vocabulary,
    parse_goals,
)

from .hostile_outputs import CORPUS, HOUSEHOLD, Case

ON = Atom("on", ("cube", "bowl"))
HOLD = Atom("holding", ("cube",))


def goals_of(text: str) -> tuple[Literal, ...]:
    r = parse_goals(text, HOUSEHOLD)
    assert r.status is GoalStatus.OK, r.errors
    assert r.errors == ()
    return r.goals


def assert_in_vocabulary(r: GoalParse, vocab: Vocabulary) -> None:
    for g in r.goals:
        atom = g.arg if isinstance(g, Not) else g
        assert isinstance(atom, Atom)
        allowed = vocab.predicates[atom.predicate]
        assert len(allowed) == len(atom.args)
        assert all(a in ok for a, ok in zip(atom.args, allowed, strict=True))


# --- the hostile corpus -----------------------------------------------------------------------


def test_corpus_is_big_and_names_are_unique() -> None:
    assert len(CORPUS) >= 60
    assert len({c.name for c in CORPUS}) == len(CORPUS)
    parser_statuses = set(GoalStatus) - LOOP_STATUSES
    assert {c.status for c in CORPUS} >= parser_statuses - {GoalStatus.OK, GoalStatus.ALREADY_TRUE}


@pytest.mark.parametrize("case", CORPUS, ids=lambda c: c.name)
def test_corpus_case(case: Case) -> None:
    r = parse_goals(case.text, HOUSEHOLD)
    assert r.status is case.status, r.errors
    assert r.goals == ()
    assert not r.ok
    assert r.errors, "a failure must explain itself"
    assert any(case.token.lower() in line.lower() for line in r.errors), r.errors
    for line in r.errors:
        assert "\n" not in line
        assert len(line) < 1_000


# --- accepted forms ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "(and (on cube bowl) (holding cube))",
        "(on cube bowl) (holding cube)",
        "(on cube bowl)\n(holding cube)\n",
        "```\n(and (on cube bowl) (holding cube))\n```",
        "```pddl\n(on cube bowl)\n(holding cube)\n```",
        "```(and (on cube bowl) (holding cube))```",
        "The cube fell. The robot should retry.\n(and (on cube bowl) (holding cube))",
        "Sure! Here are the goals:\n(on cube bowl)\n(holding cube)",
        "**Goals:**\n- `(on cube bowl)`\n- `(holding cube)`\n\nHope this helps!",
        "Answer: (AND (On Cube Bowl) (HOLDING cube))",
        "(:goal (and (on cube bowl) (holding cube)))",
        "(and ; the main goal\n  (on cube bowl)\n  (holding cube))  ; done",
        "(and (on **cube** bowl) (holding cube))",
        '{"goals": ["(on cube bowl)", "(holding cube)"]}',
        '{"goals": [{"predicate": "on", "args": ["cube", "bowl"], "negated": false},'
        ' {"predicate": "holding", "args": ["cube"], "negated": false}]}',
        '{"goals": [{"predicate": "ON", "args": ["Cube", "bowl"]}, "(holding cube)"]}',
        '```json\n{"goals": ["(on cube bowl)", "(holding cube)"]}\n```',
        'Here you go: {"goals": ["(on cube bowl)", "(holding cube)"]} -- good luck',
        '{"goals": ["(on cube bowl)", "(holding cube)"], "note": "Answer: (on apple sink)"}',
        "(and (on cube bowl) (holding cube) (on cube bowl))",
    ],
)
def test_accepted_forms(text: str) -> None:
    assert goals_of(text) == (ON, HOLD)


def test_negation_in_every_form() -> None:
    want = (ON, Not(HOLD))
    assert goals_of("(and (on cube bowl) (not (holding cube)))") == want
    assert goals_of("(on cube bowl)\n(not (holding cube))") == want
    assert goals_of('{"goals": ["(on cube bowl)", "(not (holding cube))"]}') == want
    js = {
        "goals": [
            {"predicate": "on", "args": ["cube", "bowl"], "negated": False},
            {"predicate": "holding", "args": ["cube"], "negated": True},
        ]
    }
    assert goals_of(json.dumps(js)) == want


def test_bowl_is_both_object_and_region() -> None:
    assert goals_of("(on bowl table2_left)") == (Atom("on", ("bowl", "table2_left")),)
    assert goals_of("(on apple bowl)") == (Atom("on", ("apple", "bowl")),)


# --- the extraction rule ----------------------------------------------------------------------


def test_last_code_block_wins() -> None:
    text = "```\n(on cube bowl)\n```\nWait, better:\n```\n(holding cube)\n```"
    r = parse_goals(text, HOUSEHOLD)
    assert r.goals == (HOLD,)
    assert r.source == "(holding cube)"


def test_last_and_wins_and_other_lists_are_ignored() -> None:
    text = "(and (on cube bowl))\nHmm, no:\n(and (holding cube)) (on apple sink)"
    r = parse_goals(text, HOUSEHOLD)
    assert r.goals == (HOLD,)
    assert r.source == "(and (holding cube))"


def test_last_marker_wins() -> None:
    text = "Goals: (on cube bowl)\nFinal answer: (holding cube)"
    assert goals_of(text) == (HOLD,)


def test_marker_after_last_block_wins_and_block_after_marker_wins() -> None:
    assert goals_of("```\n(on cube bowl)\n```\nAnswer: (holding cube)") == (HOLD,)
    assert goals_of("Answer: let me think.\n```\n(holding cube)\n```") == (HOLD,)


def test_marker_inside_the_last_block_cuts_it() -> None:
    text = "```\nreasoning (the cube fell)\nGoals: (holding cube)\n```"
    assert goals_of(text) == (HOLD,)


def test_unclosed_final_fence_runs_to_the_end() -> None:
    assert goals_of("```pddl\n(and (holding cube))") == (HOLD,)


def test_prose_with_parentheses_is_read_without_a_marker() -> None:
    r = parse_goals("Put it back (carefully).\n(on cube bowl)", HOUSEHOLD)
    assert r.status is GoalStatus.UNKNOWN_PREDICATE
    assert "carefully" in r.errors[0]


# --- validation -------------------------------------------------------------------------------


def test_first_status_is_reported_and_every_problem_listed() -> None:
    text = "(and (on cube table9) (at cube bowl) (on bowl cube) (holding ?x) (on cube))"
    r = parse_goals(text, HOUSEHOLD)
    assert r.status is GoalStatus.UNKNOWN_OBJECT
    assert len(r.errors) == 5
    assert "table9" in r.errors[0]
    assert "'at'" in r.errors[1] and "on/2" in r.errors[1]
    assert "'cube' cannot be argument 2" in r.errors[2]
    assert "?x" in r.errors[3]
    assert "takes 2" in r.errors[4]


def test_unknown_predicate_message_lists_goal_predicates() -> None:
    r = parse_goals("(at cube table2)", HOUSEHOLD)
    assert r.errors == (
        "unknown predicate 'at' in (at cube table2); goal predicates: cleaned/1, cooked/1, "
        "cooled/1, heated/1, holding/1, on/2, open/1, scanned/1",
    )


def test_wrong_kind_message_lists_allowed_objects() -> None:
    (line,) = parse_goals("(open sink)", HOUSEHOLD).errors
    assert line.startswith("'sink' cannot be argument 1 of 'open' in (open sink); allowed: ")
    assert "drawer1" in line and "fridge" in line


def test_error_lines_are_capped() -> None:
    text = "(and " + " ".join(f"(on cube nowhere{i})" for i in range(30)) + ")"
    r = parse_goals(text, HOUSEHOLD)
    assert len(r.errors) == MAX_ERRORS + 1
    assert r.errors[-1] == f"... and {30 - MAX_ERRORS} more problems"


def test_duplicates_are_removed_in_order() -> None:
    text = "(and (holding cube) (on cube bowl) (HOLDING cube) (on cube bowl))"
    assert goals_of(text) == (HOLD, ON)


def test_all_goals_already_true() -> None:
    r = parse_goals("(and (on cube bowl) (not (holding cube)))", HOUSEHOLD, holds=lambda g: True)
    assert r.status is GoalStatus.ALREADY_TRUE
    assert r.goals == ()
    assert "(on cube bowl)" in r.errors[0] and "(not (holding cube))" in r.errors[0]


def test_some_goals_already_true_are_dropped_with_a_note() -> None:
    r = parse_goals("(and (on cube bowl) (holding cube))", HOUSEHOLD, holds=lambda g: g == ON)
    assert r.ok
    assert r.goals == (HOLD,)
    assert r.errors == ()
    assert r.notes == ("dropped (on cube bowl): it already holds",)


def test_holds_is_not_called_when_the_answer_is_invalid() -> None:
    def boom(g: Literal) -> bool:
        raise AssertionError("must not be called")

    assert (
        parse_goals("(on cube nowhere)", HOUSEHOLD, holds=boom).status is GoalStatus.UNKNOWN_OBJECT
    )


def test_exactly_at_the_length_cap_is_read() -> None:
    text = "(on cube bowl)".ljust(MAX_CHARS)
    assert parse_goals(text, HOUSEHOLD).ok
    assert parse_goals(text + " ", HOUSEHOLD).errors[0].startswith("answer too long")


def test_non_text_is_a_syntax_error() -> None:
    r = parse_goals(b"(on cube bowl)", HOUSEHOLD)  # type: ignore[arg-type]
    assert r.status is GoalStatus.SYNTAX


# --- Vocabulary -------------------------------------------------------------------------------


def test_vocabulary_normalises_and_is_immutable() -> None:
    source = {"On": [["Cube"], ["Bowl", "sink"]]}
    v = Vocabulary.of(source)
    source["On"][0].append("apple")
    assert v.predicates == {"on": (frozenset({"cube"}), frozenset({"bowl", "sink"}))}
    assert isinstance(v.predicates, MappingProxyType)
    with pytest.raises(TypeError):
        v.predicates["x"] = ()  # type: ignore[index]
    assert v.objects == {"cube", "bowl", "sink"}
    assert v.arity("on") == 2 and v.arity("at") is None
    assert v == Vocabulary.of({"on": [["cube"], ["sink", "bowl"]]})
    assert hash(v) == hash(Vocabulary.of({"on": [["cube"], ["sink", "bowl"]]}))


def test_vocabulary_describe() -> None:
    v = Vocabulary.of({"on": [["cube"], ["bowl", "sink"]], "handempty": []})
    assert v.describe() == "(handempty)\n(on ?a1 ?a2) where ?a1 in {cube}; ?a2 in {bowl, sink}"


@pytest.mark.parametrize(
    "predicates",
    [
        {},
        {"on": ([],)},
        {"on ": (["cube"],)},
        {"and": (["cube"],)},
        {"or": (["cube"],)},
        {"on": (["cube bowl"],)},
        {"on": (["?x"],)},
        {"on": (["1cube"],)},
        {"on": (["cub\u0435"],)},
        {"On": (["cube"],), "on": (["cube"],)},
    ],
)
def test_vocabulary_rejects_bad_names(predicates: dict[str, tuple[list[str], ...]]) -> None:
    with pytest.raises(ValueError):
        Vocabulary.of(predicates)


def test_vocabulary_rejects_strings_as_collections() -> None:
    with pytest.raises(TypeError):
        Vocabulary({"on": "cube"})  # type: ignore[dict-item]
    with pytest.raises(TypeError):
        Vocabulary({"on": ("cube",)})  # type: ignore[dict-item]


# --- properties -------------------------------------------------------------------------------

NAMES = sorted(HOUSEHOLD.objects | set(HOUSEHOLD.predicates))
PIECES = [
    *NAMES,
    "(",
    ")",
    " ",
    "\n",
    "and",
    "not",
    "or",
    "?x",
    "3",
    ";",
    "```",
    "Goals:",
    "{",
    "}",
    '"goals"',
    ":",
    "[",
    "]",
    ",",
    '"',
    "\u200b",
    "\u043e",
]


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=400))
def test_arbitrary_text_never_raises(text: str) -> None:
    r = parse_goals(text, HOUSEHOLD)
    assert isinstance(r, GoalParse)
    assert r.ok == (r.errors == ())
    assert_in_vocabulary(r, HOUSEHOLD)


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(PIECES), max_size=60).map("".join))
def test_near_miss_text_never_raises_nor_leaks(text: str) -> None:
    r = parse_goals(text, HOUSEHOLD)
    assert r.ok == (r.errors == ())
    if r.ok:
        assert r.goals
    assert_in_vocabulary(r, HOUSEHOLD)


def _literal_strategy(vocab: Vocabulary) -> st.SearchStrategy[Literal]:
    def build(pred: str) -> st.SearchStrategy[Literal]:
        args = st.tuples(*(st.sampled_from(sorted(s)) for s in vocab.predicates[pred]))
        atoms = args.map(lambda a: Atom(pred, a))
        return st.one_of(atoms, atoms.map(Not))

    return st.sampled_from(sorted(vocab.predicates)).flatmap(build)


@settings(max_examples=200, deadline=None)
@given(st.lists(_literal_strategy(HOUSEHOLD), min_size=1, max_size=6, unique=True))
def test_rendered_literals_round_trip(goals: list[Literal]) -> None:
    positives = {g for g in goals if isinstance(g, Atom)}
    consistent = [g for g in goals if not (isinstance(g, Not) and g.arg in positives)]
    text = "(and " + " ".join(map(str, consistent)) + ")"
    r = parse_goals(text, HOUSEHOLD)
    assert r.ok, r.errors
    assert r.goals == tuple(consistent)
