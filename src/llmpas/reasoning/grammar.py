"""Decoding constraints that make an LLM answer with goals from a :class:`Vocabulary`.

:func:`gbnf` gives a llama.cpp grammar for ``(and LIT ...)``; :func:`json_schema` a JSON schema for
OpenAI structured outputs. Everything either admits is read by
:func:`llmpas.reasoning.goals.parse_goals` (which still checks contradictions and goals that
already hold).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from llmpas.reasoning.goals import Vocabulary
from llmpas.reasoning.program import Call


def gbnf(vocab: Vocabulary, max_goals: int = 4, reasoning: int = 0) -> str:
    """A GBNF grammar (root rule ``root``) admitting exactly ``(and LIT+)`` with 1..max_goals
    literals separated by single spaces; ``LIT`` is ``(pred arg...)`` or ``(not (pred arg...))``
    with each argument one of the objects allowed at its position.

    With ``reasoning > 0`` the answer starts with ``Reasoning: `` and one line of free text of at
    most that many characters, then ``\nGoals: (and ...)``: a small model can say what it will do
    before the goals are forced (with goals only, it tends to fall back to the task goal).

    Rule names are ``p<i>`` / ``p<i>-a<j>`` so they are valid whatever the predicate names.
    """
    _check_max_goals(max_goals)
    if isinstance(reasoning, bool) or not isinstance(reasoning, int) or reasoning < 0:
        raise ValueError(f"reasoning must be a non-negative integer, got {reasoning!r}")
    names = list(vocab.predicates)
    goals = f'"(and " lit {_optional_more(max_goals - 1)}")"'
    head = (
        ['root ::= "Reasoning: " reason "\\nGoals: " goals', f"reason ::= [^\\n]{{1,{reasoning}}}"]
        if reasoning
        else ["root ::= goals"]
    )
    rules = [
        *head,
        f"goals ::= {goals}",
        'lit ::= atom | "(not " atom ")"',
        "atom ::= " + " | ".join(f"p{i}" for i in range(len(names))),
    ]
    for i, name in enumerate(names):
        allowed = vocab.predicates[name]
        parts = [_literal("(" + name)]
        for j in range(len(allowed)):
            parts += ['" "', f"p{i}-a{j + 1}"]
        rules.append(f"p{i} ::= " + " ".join([*parts, '")"']))
        for j, objects in enumerate(allowed, 1):
            rules.append(f"p{i}-a{j} ::= " + " | ".join(_literal(o) for o in sorted(objects)))
    return "\n".join(rules) + "\n"


def skill_gbnf(calls: Mapping[str, Call], vocab: Vocabulary, reasoning: int = 200) -> str:
    """A GBNF grammar for one Inner-Monologue step: ``Robot thought: <one line>`` then
    ``Robot action: skill("arg", ...)`` calling one of ``calls`` with, at each argument, an object
    the goal vocabulary allows where the skill's effect puts that argument."""
    if isinstance(reasoning, bool) or not isinstance(reasoning, int) or reasoning < 1:
        raise ValueError(f"reasoning must be a positive integer, got {reasoning!r}")
    names = sorted(calls)
    rules = [
        'root ::= "Robot thought: " reason "\\nRobot action: " call',
        f"reason ::= [^\\n]{{1,{reasoning}}}",
        "call ::= " + " | ".join(f"c{i}" for i in range(len(names))),
    ]
    everything = vocab.objects
    for i, name in enumerate(names):
        spec = calls[name]
        allowed = vocab.predicates.get(spec.predicate, ())
        parts = [_literal(name + '("')]
        for j in range(len(spec.params)):
            if j:
                parts.append(_literal('", "'))
            parts.append(f"c{i}-a{j + 1}")
            where = [k for k, pos in enumerate(spec.positions) if pos == j]
            objects = allowed[where[0]] if where and where[0] < len(allowed) else everything
            rules.append(f"c{i}-a{j + 1} ::= " + " | ".join(_literal(o) for o in sorted(objects)))
        rules.insert(3 + i, f"c{i} ::= " + " ".join([*parts, _literal('")')]))
    return "\n".join(rules) + "\n"


def _optional_more(n: int) -> str:
    """``(" " lit (" " lit)?)? `` nested n deep (empty for n == 0)."""
    text = ""
    for _ in range(n):
        text = f'(" " lit {text})? ' if text else '(" " lit)? '
    return text


def _literal(text: str) -> str:
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
