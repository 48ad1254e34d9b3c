"""gbnf and json_schema: structure, exact correspondence to the vocabulary, and agreement with
parse_goals on everything they admit."""

from __future__ import annotations

import itertools
import json
import random
import re
from typing import Any

import pytest

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import GoalStatus, Literal, parse_goals
from llmpas.reasoning.grammar import gbnf, json_schema
from llmpas.reasoning.tables import Vocabulary

from ..tiny_model import needs_tiny_model, tiny_backend
from ..tiny_model import sample as tiny_sample
from .hostile_outputs import HOUSEHOLD

TINY = Vocabulary.of(
    {"on": (["cube", "bowl"], ["bowl", "sink"]), "holding": (["cube"],), "handempty": ()}
)

# --- a tiny reader for the GBNF subset gbnf() emits: literals, rule names, |, ( ), ? -----------

_TOKEN = re.compile(r'\s*("(?:[^"\\]|\\.)*"|[a-z0-9-]+|[()|?])')
Expr = tuple[Any, ...]  # ("lit", s) | ("ref", name) | ("seq", [..]) | ("alt", [..]) | ("opt", e)


def read_grammar(text: str) -> dict[str, Expr]:
    rules: dict[str, Expr] = {}
    for line in text.splitlines():
        if not line.strip():
            continue
        name, _, body = line.partition(" ::= ")
        assert re.fullmatch(r"[a-z0-9-]+", name), name
        assert name not in rules, f"rule {name} defined twice"
        tokens = _tokenize(body)
        expr, rest = _alt(tokens)
        assert not rest, f"trailing tokens in {line!r}"
        rules[name] = expr
    return rules


def _tokenize(body: str) -> list[str]:
    tokens, i = [], 0
    while body[i:].strip():
        m = _TOKEN.match(body, i)
        assert m, f"cannot read {body[i:]!r}"
        tokens.append(m.group(1))
        i = m.end()
    return tokens


def _alt(tokens: list[str]) -> tuple[Expr, list[str]]:
    options = []
    seq, tokens = _seq(tokens)
    options.append(seq)
    while tokens and tokens[0] == "|":
        seq, tokens = _seq(tokens[1:])
        options.append(seq)
    return ("alt", options), tokens


def _seq(tokens: list[str]) -> tuple[Expr, list[str]]:
    items: list[Expr] = []
    while tokens and tokens[0] not in "|)":
        tok, tokens = tokens[0], tokens[1:]
        if tok == "(":
            item, tokens = _alt(tokens)
            assert tokens[0] == ")"
            tokens = tokens[1:]
        elif tok.startswith('"'):
            item = ("lit", re.sub(r"\\(.)", r"\1", tok[1:-1]))
        else:
            item = ("ref", tok)
        if tokens and tokens[0] == "?":
            item, tokens = ("opt", item), tokens[1:]
        items.append(item)
    return ("seq", items), tokens


def language(rules: dict[str, Expr], expr: Expr) -> frozenset[str]:
    """Every string ``expr`` derives (the grammar is not recursive, so this is finite)."""
    kind, arg = expr
    if kind == "lit":
        return frozenset({arg})
    if kind == "ref":
        return language(rules, rules[arg])
    if kind == "opt":
        return language(rules, arg) | {""}
    if kind == "alt":
        return frozenset().union(*(language(rules, e) for e in arg))
    parts = [language(rules, e) for e in arg]
    return frozenset("".join(p) for p in itertools.product(*parts))


def sample(rules: dict[str, Expr], expr: Expr, rng: random.Random) -> str:
    kind, arg = expr
    if kind == "lit":
        return str(arg)
    if kind == "ref":
        return sample(rules, rules[arg], rng)
    if kind == "opt":
        return sample(rules, arg, rng) if rng.random() < 0.6 else ""
    if kind == "alt":
        return sample(rules, rng.choice(arg), rng)
    return "".join(sample(rules, e, rng) for e in arg)


def all_literals(vocab: Vocabulary) -> list[Literal]:
    out: list[Literal] = []
    for pred, allowed in vocab.predicates.items():
        for args in itertools.product(*(sorted(s) for s in allowed)):
            atom = Atom(pred, args)
            out += [atom, Not(atom)]
    return out


# --- gbnf -------------------------------------------------------------------------------------


def refs(expr: Expr) -> set[str]:
    kind, arg = expr
    if kind == "ref":
        return {arg}
    if kind == "opt":
        return refs(arg)
    if kind in ("seq", "alt"):
        return set().union(*(refs(e) for e in arg))
    return set()


def test_gbnf_structure() -> None:
    g = gbnf(HOUSEHOLD)
    rules = read_grammar(g)
    assert g.startswith("root ::= ")
    used = set().union(*(refs(e) for e in rules.values()))
    assert used <= set(rules), "every referenced rule is defined"
    assert set(rules) - used == {"root"}, "every rule is reachable"
    for name in HOUSEHOLD.predicates:
        assert f'"({name}"' in g
    for name in HOUSEHOLD.objects:
        assert f'"{name}"' in g


def test_gbnf_language_is_exactly_the_vocabulary() -> None:
    rules = read_grammar(gbnf(TINY, max_goals=2))
    lits = [str(lit) for lit in all_literals(TINY)]
    assert language(rules, ("ref", "lit")) == set(lits)
    expected = {f"(and {a})" for a in lits} | {f"(and {a} {b})" for a in lits for b in lits}
    assert language(rules, ("ref", "root")) == expected


@pytest.mark.parametrize("max_goals", [1, 2, 3, 4, 7])
def test_gbnf_bounds_the_number_of_goals(max_goals: int) -> None:
    rules = read_grammar(gbnf(Vocabulary.of({"handempty": ()}), max_goals))
    lits = ["(handempty)", "(not (handempty))"]
    expected = {
        "(and " + " ".join(seq) + ")"
        for n in range(1, max_goals + 1)
        for seq in itertools.product(lits, repeat=n)
    }
    assert language(rules, ("ref", "root")) == expected


def test_strings_sampled_from_the_grammar_parse() -> None:
    rules = read_grammar(gbnf(HOUSEHOLD, max_goals=4))
    rng = random.Random(7)
    seen_ok = 0
    for _ in range(500):
        text = sample(rules, ("ref", "root"), rng)
        r = parse_goals(text, HOUSEHOLD)
        assert r.status in (GoalStatus.OK, GoalStatus.CONTRADICTORY), (text, r.errors)
        seen_ok += r.ok
        assert 1 <= len(r.goals) <= 4 or not r.ok
    assert seen_ok > 400


def test_strings_built_from_the_vocabulary_are_in_the_grammar_and_parse() -> None:
    rules = read_grammar(gbnf(TINY, max_goals=3))
    root = language(rules, ("ref", "root"))
    rng = random.Random(3)
    lits = all_literals(TINY)
    for _ in range(200):
        goals = rng.sample(lits, rng.randint(1, 3))
        text = "(and " + " ".join(map(str, goals)) + ")"
        assert text in root
        r = parse_goals(text, TINY)
        assert r.status in (GoalStatus.OK, GoalStatus.CONTRADICTORY)


@pytest.mark.parametrize(
    "exclude",
    [
        [Atom("on", ("cube", "bowl"))],
        [Not(Atom("holding", ("cube",)))],
        [Atom("on", ("cube", "sink")), Not(Atom("on", ("bowl", "bowl"))), Atom("handempty")],
    ],
)
def test_excluded_literals_are_exactly_what_the_grammar_leaves_out(exclude: list[Literal]) -> None:
    rules = read_grammar(gbnf(TINY, max_goals=1, exclude=exclude))
    lits = {str(lit) for lit in all_literals(TINY)}
    assert language(rules, ("ref", "lit")) == lits - set(map(str, exclude))


def test_excluding_every_grounding_of_a_predicate_drops_it() -> None:
    vocab = Vocabulary.of({"scanned": (["t1", "t2"],), "holding": (["cube"],)})
    gone = [Atom("scanned", ("t1",)), Atom("scanned", ("t2",))]
    rules = read_grammar(gbnf(vocab, max_goals=1, exclude=gone))
    assert language(rules, ("ref", "lit")) == {
        "(holding cube)",
        "(not (holding cube))",
        "(not (scanned t1))",
        "(not (scanned t2))",
    }
    rules = read_grammar(gbnf(vocab, max_goals=1, exclude=[Atom("holding", ("cube",)), *gone]))
    assert language(rules, ("ref", "lit")) == {
        "(not (holding cube))",
        "(not (scanned t1))",
        "(not (scanned t2))",
    }
    everything = [*all_literals(vocab)]
    with pytest.raises(ValueError, match="every goal literal is excluded"):
        gbnf(vocab, exclude=everything)


def test_exclusions_beyond_the_grounding_limit_leave_the_predicate_open() -> None:
    from llmpas.reasoning.grammar import MAX_GROUNDINGS

    objects = [f"o{i}" for i in range(MAX_GROUNDINGS + 1)]
    vocab = Vocabulary.of({"at": (objects,)})
    rules = read_grammar(gbnf(vocab, max_goals=1, exclude=[Atom("at", ("o1",))]))
    assert language(rules, ("ref", "lit")) == {str(lit) for lit in all_literals(vocab)}


def test_no_exclusion_gives_the_same_grammar() -> None:
    assert gbnf(HOUSEHOLD, reasoning=200, exclude=()) == gbnf(HOUSEHOLD, reasoning=200)


def test_gbnf_escapes_string_literals() -> None:
    from llmpas.reasoning.grammar import literal as _literal

    assert _literal('a"b\\c') == r'"a\"b\\c"'
    assert _literal("x\ny\t\u00e9") == r'"x\ny\t\u00e9"'


@pytest.mark.parametrize("bad", [0, -1, True, 2.0])
def test_max_goals_must_be_positive(bad: Any) -> None:
    with pytest.raises(ValueError):
        gbnf(TINY, bad)
    with pytest.raises(ValueError):
        json_schema(TINY, bad)


def split_reasoning(grammar: str) -> tuple[str, str, str]:
    """(root rule, reason rule, the rest) of a grammar with a reasoning line."""
    root, reason, rest = grammar.split("\n", 2)
    return root, reason, rest


def test_reasoning_line_comes_before_the_same_goals() -> None:
    plain = gbnf(TINY, max_goals=2)
    root, reason, rest = split_reasoning(gbnf(TINY, max_goals=2, reasoning=150))
    assert root == 'root ::= "Reasoning: " reason "\\nGoals: " goals'
    assert reason == "reason ::= [^\\n]{1,150}"  # one line, bounded: it cannot run on
    assert plain == "root ::= goals\n" + rest, "the goal rules are the same with or without it"
    rules = read_grammar(rest)
    lits = [str(lit) for lit in all_literals(TINY)]
    assert language(rules, ("ref", "goals")) >= {f"(and {a})" for a in lits}


def test_answers_with_a_reasoning_line_parse_to_their_goals() -> None:
    rules = read_grammar(split_reasoning(gbnf(HOUSEHOLD, reasoning=200))[2])
    rng = random.Random(11)
    for _ in range(100):
        goals = sample(rules, ("ref", "goals"), rng)
        text = f"Reasoning: the cube (on cube table1) is gone, so look (scanned x).\nGoals: {goals}"
        assert parse_goals(text, HOUSEHOLD).source == parse_goals(goals, HOUSEHOLD).source


def test_every_skill_call_the_grammar_admits_parses_to_its_effect() -> None:
    from llmpas.reasoning.grammar import skill_gbnf
    from llmpas.reasoning.program import parse_program
    from llmpas.worlds.household.household_reasoning import PROGRAM_CALLS

    grammar = skill_gbnf(PROGRAM_CALLS, HOUSEHOLD, reasoning=80)
    head, reason, rest = grammar.split("\n", 2)
    assert head == 'root ::= "Robot thought: " reason "\\nRobot action: " call'
    assert reason == "reason ::= [^\\n]{1,80}"
    rules = read_grammar(rest)
    calls = language(rules, ("ref", "call"))
    assert any(c.startswith('place("') for c in calls)
    for call in calls:
        r = parse_program(call, PROGRAM_CALLS, HOUSEHOLD)
        assert r.status in (GoalStatus.OK, GoalStatus.CONTRADICTORY), (call, r.errors)
        assert len(r.goals) == 1
    assert 'close("microwave")' in calls
    assert str(parse_program('close("microwave")', PROGRAM_CALLS, HOUSEHOLD).goals[0]) == (
        "(not (open microwave))"
    )


@pytest.mark.parametrize("bad", [-1, True, 2.5])
def test_reasoning_length_must_be_a_non_negative_integer(bad: Any) -> None:
    with pytest.raises(ValueError, match="reasoning"):
        gbnf(TINY, reasoning=bad)


# --- llama.cpp decoding under the grammars (the tiny real model) -------------------------------

PROMPTS = (
    "The cube fell off the table and is lost. Which goals should the robot pursue?",
    "The microwave door is blocked by a mug. Propose goals.",
)


@needs_tiny_model
@pytest.mark.parametrize("reasoning", [0, 60])
def test_llama_cpp_decodes_only_what_the_goal_grammar_admits(reasoning: int) -> None:
    """llama.cpp parses the grammar and samples under it: every answer is in the grammar's
    language (read by this file's own GBNF reader), parses into goals from the vocabulary, and
    never holds an excluded literal. Structure only: the text itself is the model's."""
    excluded = all_literals(HOUSEHOLD)[:40]
    grammar = gbnf(HOUSEHOLD, reasoning=reasoning, exclude=excluded)
    goal_rules = "\n".join(x for x in grammar.splitlines() if not x.startswith(("root", "reason")))
    lits = language(read_grammar(goal_rules), ("ref", "lit"))
    llm = tiny_backend()
    for prompt in PROMPTS:
        text = tiny_sample(llm, grammar, prompt, max_tokens=96 + reasoning)
        if reasoning:
            head, sep, text = text.partition("\nGoals: ")
            assert sep and head.startswith("Reasoning: ") and "\n" not in head
            assert 1 <= len(head) - len("Reasoning: ") <= reasoning
        parse = parse_goals(text, HOUSEHOLD)
        assert parse.ok, (text, parse.errors)
        assert text == "(and " + " ".join(map(str, parse.goals)) + ")"
        assert all(str(g) in lits for g in parse.goals)
        assert not set(parse.goals) & set(excluded)


@needs_tiny_model
def test_llama_cpp_decodes_only_skill_calls_the_skill_grammar_admits() -> None:
    from llmpas.reasoning.grammar import skill_gbnf
    from llmpas.reasoning.program import parse_program
    from llmpas.worlds.household.household_reasoning import PROGRAM_CALLS

    grammar = skill_gbnf(PROGRAM_CALLS, HOUSEHOLD, reasoning=60)
    calls = language(read_grammar(grammar.split("\n", 2)[2]), ("ref", "call"))
    llm = tiny_backend()
    for prompt in PROMPTS:
        text = tiny_sample(llm, grammar, prompt, max_tokens=96)
        thought, sep, call = text.partition("\nRobot action: ")
        assert sep and thought.startswith("Robot thought: ")
        assert call in calls
        assert len(parse_program(call, PROGRAM_CALLS, HOUSEHOLD).goals) == 1


# --- json_schema ------------------------------------------------------------------------------


def as_json(goals: list[Literal]) -> dict[str, Any]:
    items = []
    for g in goals:
        atom = g.arg if isinstance(g, Not) else g
        assert isinstance(atom, Atom)
        items.append(
            {"predicate": atom.predicate, "args": list(atom.args), "negated": isinstance(g, Not)}
        )
    return {"goals": items}


def test_json_schema_structure() -> None:
    s = json_schema(HOUSEHOLD, max_goals=3)
    assert s["type"] == "object" and s["required"] == ["goals"]
    assert s["additionalProperties"] is False
    goals = s["properties"]["goals"]
    assert (goals["minItems"], goals["maxItems"]) == (1, 3)
    branches = goals["items"]["anyOf"]
    assert [b["properties"]["predicate"]["const"] for b in branches] == list(HOUSEHOLD.predicates)
    for b in branches:
        pred = b["properties"]["predicate"]["const"]
        allowed = HOUSEHOLD.predicates[pred]
        args = b["properties"]["args"]
        assert args["minItems"] == args["maxItems"] == len(allowed)
        assert [set(p["enum"]) for p in args["prefixItems"]] == [set(a) for a in allowed]
        assert b["required"] == ["predicate", "args", "negated"]
        assert b["additionalProperties"] is False
    assert json_schema(HOUSEHOLD) is not json_schema(HOUSEHOLD)
    json.dumps(s)


def test_json_built_from_the_vocabulary_parses() -> None:
    rng = random.Random(5)
    lits = all_literals(HOUSEHOLD)
    for _ in range(200):
        goals = rng.sample(lits, rng.randint(1, 4))
        r = parse_goals(json.dumps(as_json(goals)), HOUSEHOLD)
        assert r.status in (GoalStatus.OK, GoalStatus.CONTRADICTORY), r.errors


def test_json_schema_validates_with_jsonschema() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    schema = json_schema(TINY, max_goals=2)
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    lits = all_literals(TINY)
    for a, b in itertools.product(lits, repeat=2):
        instance = as_json([a, b])
        assert validator.is_valid(instance)
        r = parse_goals(json.dumps(instance), TINY)
        assert r.status in (GoalStatus.OK, GoalStatus.CONTRADICTORY)
    good = {"predicate": "on", "args": ["cube", "sink"], "negated": False}
    bad_instances = [
        {},
        {"goals": []},
        {"goals": [good, good, good]},
        {"goals": [{**good, "args": ["sink", "cube"]}]},
        {"goals": [{**good, "args": ["cube"]}]},
        {"goals": [{**good, "args": ["cube", "sink", "bowl"]}]},
        {"goals": [{**good, "predicate": "at"}]},
        {"goals": [{**good, "extra": 1}]},
        {"goals": [{"predicate": "on", "args": ["cube", "sink"]}]},
        {"goals": [{"predicate": "handempty", "args": ["cube"], "negated": False}]},
        {"goals": ["(on cube sink)"]},
        {"goals": [good], "why": "because"},
    ]
    for bad in bad_instances:
        assert not validator.is_valid(bad), bad
