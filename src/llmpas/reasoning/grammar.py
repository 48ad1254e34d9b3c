"""Decoding constraints that make an LLM answer with goals from a :class:`Vocabulary`.

:func:`gbnf` gives a llama.cpp grammar for ``(and LIT ...)``; :func:`json_schema` a JSON schema for
OpenAI structured outputs. Everything either admits is read by
:func:`llmpas.reasoning.goal_reading.parse_goals` (which still checks contradictions and goals that
already hold).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection, Mapping
from typing import Any

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.goal_reading import Literal
from llmpas.reasoning.tables import Call, Vocabulary


def gbnf(
    vocab: Vocabulary,
    max_goals: int = 4,
    reasoning: int = 0,
    exclude: Collection[Literal] = (),
) -> str:
    """A GBNF grammar (root rule ``root``) admitting exactly ``(and LIT+)`` with 1..max_goals
    literals separated by single spaces; ``LIT`` is ``(pred arg...)`` or ``(not (pred arg...))``
    with each argument one of the objects allowed at its position.

    With ``reasoning > 0`` the answer starts with ``Reasoning: `` and one line of free text of at
    most that many characters, then ``\nGoals: (and ...)``: a small model can say what it will do
    before the goals are forced (with goals only, it tends to fall back to the task goal).

    ``exclude`` lists ground literals the answer must not contain (goals already rejected): a
    predicate with excluded atoms is spelled out as its remaining groundings (up to
    :data:`MAX_GROUNDINGS`; beyond that it stays open and the validator rejects the repeat).

    Rule names are ``p<i>`` / ``p<i>-a<j>`` (``n<i>...`` inside ``not``) so they are valid whatever
    the predicate names.
    """
    _check_max_goals(max_goals)
    if isinstance(reasoning, bool) or not isinstance(reasoning, int) or reasoning < 0:
        raise ValueError(f"reasoning must be a non-negative integer, got {reasoning!r}")
    goals = f'"(and " lit {_optional_more(max_goals - 1)}")"'
    head = (
        ['root ::= "Reasoning: " reason "\\nGoals: " goals', f"reason ::= [^\\n]{{1,{reasoning}}}"]
        if reasoning
        else ["root ::= goals"]
    )
    positive = {g for g in exclude if isinstance(g, Atom)}
    negative = {g.arg for g in exclude if isinstance(g, Not) and isinstance(g.arg, Atom)}
    atoms = _atoms("atom", "p", vocab, positive)
    natoms: list[str] = []
    inner = "atom" if atoms else ""  # the rule inside (not ...): its own when exclusions differ
    if negative != positive:
        natoms = _atoms("natom", "n", vocab, negative)
        inner = "natom" if natoms else ""
    lit = (["atom"] if atoms else []) + ([f'"(not " {inner} ")"'] if inner else [])
    if not lit:
        raise ValueError("every goal literal is excluded: nothing is left to propose")
    rules = [*head, f"goals ::= {goals}", "lit ::= " + " | ".join(lit), *atoms, *natoms]
    return "\n".join(rules) + "\n"


MAX_GROUNDINGS = 400
"""Most groundings of one predicate :func:`gbnf` spells out to leave excluded literals out."""


def _atoms(rule: str, prefix: str, vocab: Vocabulary, exclude: set[Atom]) -> list[str]:
    """``rule ::= <prefix>0 | <prefix>1 ...``, one alternative per predicate, each either open
    (any allowed object per position) or its groundings minus ``exclude``."""
    names = list(vocab.predicates)
    rules: list[str] = []
    alternatives = []
    for i, name in enumerate(names):
        allowed = vocab.predicates[name]
        banned = {a.args for a in exclude if a.predicate == name and len(a.args) == len(allowed)}
        size = math.prod(len(objects) for objects in allowed)
        if banned and size <= MAX_GROUNDINGS:
            kept = [args for args in itertools.product(*map(sorted, allowed)) if args not in banned]
            if kept:
                alternatives.append(f"{prefix}{i}")
                text = (literal("(" + " ".join((name, *args)) + ")") for args in kept)
                rules.append(f"{prefix}{i} ::= " + " | ".join(text))
            continue
        alternatives.append(f"{prefix}{i}")
        parts = [literal("(" + name)]
        for j in range(len(allowed)):
            parts += ['" "', f"{prefix}{i}-a{j + 1}"]
        rules.append(f"{prefix}{i} ::= " + " ".join([*parts, '")"']))
        for j, objects in enumerate(allowed, 1):
            rules.append(f"{prefix}{i}-a{j} ::= " + " | ".join(literal(o) for o in sorted(objects)))
    if not alternatives:
        return []
    return [f"{rule} ::= " + " | ".join(alternatives), *rules]


def skill_gbnf(calls: Mapping[str, Call], vocab: Vocabulary, reasoning: int = 200) -> str:
    """A GBNF grammar for one Inner-Monologue step: ``Robot thought: <one line>`` then
    ``Robot action: skill("arg", ...)`` calling one of ``calls`` with, at each argument, an object
    the goal vocabulary allows where the skill's effect puts that argument (skills whose effect
    is not a goal predicate of the vocabulary are left out)."""
    if isinstance(reasoning, bool) or not isinstance(reasoning, int) or reasoning < 1:
        raise ValueError(f"reasoning must be a positive integer, got {reasoning!r}")
    names = sorted(n for n in calls if calls[n].predicate in vocab.predicates)  # reachable goals
    if not names:
        raise ValueError("no skill makes a goal predicate of the vocabulary true")
    rules = [
        'root ::= "Robot thought: " reason "\\nRobot action: " call',
        f"reason ::= [^\\n]{{1,{reasoning}}}",
        "call ::= " + " | ".join(f"c{i}" for i in range(len(names))),
    ]
    everything = vocab.objects
    for i, name in enumerate(names):
        spec = calls[name]
        allowed = vocab.predicates.get(spec.predicate, ())
        parts = [literal(name + '("')]
        for j in range(len(spec.params)):
            if j:
                parts.append(literal('", "'))
            parts.append(f"c{i}-a{j + 1}")
            where = [k for k, pos in enumerate(spec.positions) if pos == j]
            objects = allowed[where[0]] if where and where[0] < len(allowed) else everything
            rules.append(f"c{i}-a{j + 1} ::= " + " | ".join(literal(o) for o in sorted(objects)))
        rules.insert(3 + i, f"c{i} ::= " + " ".join([*parts, literal('")')]))
    return "\n".join(rules) + "\n"


def _optional_more(n: int) -> str:
    """``(" " lit (" " lit)?)? `` nested n deep (empty for n == 0)."""
    text = ""
    for _ in range(n):
        text = f'(" " lit {text})? ' if text else '(" " lit)? '
    return text


def literal(text: str) -> str:
    """A GBNF string literal for ``text``."""
    out = []
    for c in text:
        if c in '"\\':
            out.append("\\" + c)
        elif c == "\n":
            out.append("\\n")
        elif c == "\r":
            out.append("\\r")
        elif c == "\t":
            out.append("\\t")
        elif not (c.isascii() and c.isprintable()):
            out.append(f"\\x{ord(c):02x}" if ord(c) < 0x80 else f"\\u{ord(c):04x}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def json_schema(vocab: Vocabulary, max_goals: int = 4) -> dict[str, Any]:
    """A JSON schema (draft 2020-12 subset accepted by OpenAI structured outputs) for
    ``{"goals": [{"predicate": ..., "args": [...], "negated": bool}, ...]}``, one ``anyOf``
    branch per predicate with its arguments restricted per position. A fresh dict each call."""
    _check_max_goals(max_goals)
    return {
        "type": "object",
        "properties": {
            "goals": {
                "type": "array",
                "items": {"anyOf": [_literal_schema(p, a) for p, a in vocab.predicates.items()]},
                "minItems": 1,
                "maxItems": max_goals,
            }
        },
        "required": ["goals"],
        "additionalProperties": False,
    }


def _literal_schema(name: str, allowed: tuple[frozenset[str], ...]) -> dict[str, Any]:
    args: dict[str, Any] = {"type": "array", "minItems": len(allowed), "maxItems": len(allowed)}
    if allowed:  # an empty prefixItems is not valid JSON schema
        args["prefixItems"] = [{"type": "string", "enum": sorted(s)} for s in allowed]
    return {
        "type": "object",
        "properties": {
            "predicate": {"type": "string", "const": name},
            "args": args,
            "negated": {"type": "boolean"},
        },
        "required": ["predicate", "args", "negated"],
        "additionalProperties": False,
    }


def _check_max_goals(max_goals: int) -> None:
    if isinstance(max_goals, bool) or not isinstance(max_goals, int) or max_goals < 1:
        raise ValueError(f"max_goals must be a positive integer, got {max_goals!r}")
