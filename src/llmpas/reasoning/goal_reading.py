"""Reading the goal literals an LLM proposes, and checking them against a vocabulary.

LLM output is data: :func:`parse_goals` reads it with a small bounded reader (no ``eval``, no
PDDL parser recursion), never raises on any string, and reports every problem as one line that
can be fed back to the LLM in a repair prompt.

Which part of the answer is read (the *answer-extraction rule*), in order:

1. Text longer than :data:`MAX_CHARS` is rejected (``SYNTAX``, "answer too long").
2. If the answer (stripped) starts with ``{`` it is JSON; nothing is cut from it.
3. Otherwise the answer is cut to the *later* of: the content of the last fenced code block
   (```` ``` ````; an unclosed final fence runs to the end; a language tag line such as ``pddl``
   is skipped) and the text after the last ``Goals:`` / ``Goal:`` / ``Answer:`` marker outside
   code blocks (case-insensitive, markdown emphasis allowed: ``**Answer:**``). Inside a chosen
   code block, a marker cuts again. No block and no marker: the whole text.
4. In that region, if it starts with ``{`` or holds ``{"goals":``, the JSON object starting there
   (the last such) is read: ``{"goals": ["(on cube bowl)", ...]}`` or
   ``{"goals": [{"predicate": "on", "args": ["cube", "bowl"], "negated": false}, ...]}``.
5. Otherwise it is read as s-expressions (``;`` starts a comment to the end of the line; words
   outside parentheses are prose and ignored, as are markdown ``*`` and backticks around names).
   A top-level ``(:goal X)`` is unwrapped. If some top-level list is ``(and ...)``, the *last* one
   holds the goals and every other list is ignored; else every top-level list is a goal literal.
   Unbalanced parentheses anywhere in the region are a ``SYNTAX`` error.

A literal is ``(pred obj...)`` or ``(not (pred obj...))``; names are lower-cased. Checks, in
document order: syntax (variables, numbers, nested formulas, connectives, quantifiers), predicate
known, arity, each argument known (``UNKNOWN_OBJECT``) and allowed at its position
(``WRONG_KIND``). Duplicates are dropped. Then ``CONTRADICTORY`` if a literal and its negation are
both asked for, then ``ALREADY_TRUE`` if ``holds`` says every goal already holds. When only some
goals already hold, those are dropped, the rest is returned with status ``OK`` and each drop is
explained in :attr:`GoalParse.notes` (``errors`` stays empty exactly when the status is ``OK``).
The reported status is that of the first problem; ``errors`` lists every problem (capped at
:data:`MAX_ERRORS` lines).
"""

from __future__ import annotations

import bisect
import enum
import json
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.tables import CONNECTIVES, Vocabulary

MAX_CHARS = 20_000
"""Longer answers are rejected unread."""
MAX_DEPTH = 16
"""Deepest parenthesis / JSON bracket nesting read; goal literals need 2 (3 with ``:goal``)."""
MAX_GOALS = 32
"""More candidate literals than this is a ``SYNTAX`` error."""
MAX_ERRORS = 12
"""Error lines kept; further problems are summarised in one extra line."""

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?\Z")
_MARKER = re.compile(r"\b(?:answer|goals?)\b[*_ \t]*:", re.IGNORECASE)
_JSON_GOALS = re.compile(r'\{\s*"goals"\s*:', re.IGNORECASE)
_FENCE = re.compile(r"```")
_TAG = re.compile(r"[A-Za-z0-9_+.-]*\Z")


class GoalStatus(enum.Enum):
    OK = "ok"
    EMPTY = "empty"
    SYNTAX = "syntax"
    UNKNOWN_PREDICATE = "unknown-predicate"
    ARITY = "arity"
    UNKNOWN_OBJECT = "unknown-object"
    WRONG_KIND = "wrong-kind"
    ALREADY_TRUE = "already-true"
    CONTRADICTORY = "contradictory"
    # set by the closed loop, which knows the history and has a planner
    REPEATED = "repeated"  # repeats an exhausted search or an attempt that did not help
    UNREACHABLE = "unreachable"  # no plan reaches it from the believed state


LOOP_STATUSES = frozenset({GoalStatus.REPEATED, GoalStatus.UNREACHABLE})
"""Statuses the closed loop sets (it knows the history and has a planner); the parser never
returns them."""

Literal = Atom | Not
"""A goal literal: an :class:`Atom` of object names, or :class:`Not` wrapping one."""


@dataclass(frozen=True)
class GoalParse:
    """The outcome of :func:`parse_goals`.

    ``goals`` holds the validated literals (empty unless OK); ``errors`` one line per problem,
    written to be fed back to the LLM (empty exactly when OK); ``source`` the part of the text the
    goals were read from; ``notes`` remarks that did not prevent success (dropped goals that
    already hold); ``rejected`` the literals a validation turned down (a repair's decoding can
    leave them out).
    """

    status: GoalStatus
    goals: tuple[Literal, ...]
    errors: tuple[str, ...]
    source: str = ""
    notes: tuple[str, ...] = ()
    rejected: tuple[Literal, ...] = ()

    @property
    def ok(self) -> bool:
        return self.status is GoalStatus.OK


@dataclass(frozen=True)
class _Issue:
    status: GoalStatus
    message: str


_Item = Atom | Not | _Issue


@dataclass(frozen=True)
class _List:
    """A parenthesised list read from the answer; ``start``/``end`` are offsets in its text."""

    items: tuple[_Node, ...]
    start: int
    end: int


_Node = str | _List


# ---------------------------------------------------------------------------------------------
# entry point


def parse_goals(
    text: str, vocab: Vocabulary, holds: Callable[[Literal], bool] | None = None
) -> GoalParse:
    """Read and check the goal literals in an LLM answer (see the module doc for the rules)."""
    if not isinstance(text, str):
        return _failed([_Issue(GoalStatus.SYNTAX, "the answer is not text")], "")
    if len(text) > MAX_CHARS:
        msg = f"answer too long: {len(text)} characters (at most {MAX_CHARS}); give only the goals"
        return _failed([_Issue(GoalStatus.SYNTAX, msg)], "")
    source, items = _candidates(_answer_region(text))
    literals, issues = _validate(items, vocab)
    if issues:
        return _failed(issues, source)
    goals = tuple(dict.fromkeys(literals))
    clashes = _contradictions(goals)
    if clashes:
        return _failed(clashes, source)
    return _drop_true(goals, holds, source)


def _failed(issues: Sequence[_Issue], source: str) -> GoalParse:
    lines = [i.message for i in issues[:MAX_ERRORS]]
    if len(issues) > MAX_ERRORS:
        lines.append(f"... and {len(issues) - MAX_ERRORS} more problems")
    return GoalParse(issues[0].status, (), tuple(lines), source)


def _validate(items: Sequence[_Item], vocab: Vocabulary) -> tuple[list[Literal], list[_Issue]]:
    if not items:
        return [], [_Issue(GoalStatus.EMPTY, "no goal literals found")]
    literal_count = sum(not isinstance(i, _Issue) for i in items)
    if literal_count > MAX_GOALS:
        msg = f"too many goals: {literal_count} (at most {MAX_GOALS}); give only the needed goals"
        return [], [_Issue(GoalStatus.SYNTAX, msg)]
    objects = vocab.objects
    literals: list[Literal] = []
    issues: list[_Issue] = []
    for item in items:
        if isinstance(item, _Issue):
            issues.append(item)
            continue
        problems = _check(item, vocab, objects)
        issues.extend(problems)
        if not problems:
            literals.append(item)
    return literals, issues


def _contradictions(goals: Sequence[Literal]) -> list[_Issue]:
    present = set(goals)
    return [
        _Issue(
            GoalStatus.CONTRADICTORY,
            f"contradictory goals: {_show_lit(g.arg)} and {_show_lit(g)}; keep only one of them",
        )
        for g in goals
        if isinstance(g, Not) and g.arg in present
    ]


def _drop_true(
    goals: tuple[Literal, ...], holds: Callable[[Literal], bool] | None, source: str
) -> GoalParse:
    true = [g for g in goals if holds is not None and holds(g)]
    if goals and len(true) == len(goals):
        shown = ", ".join(_show_lit(g) for g in goals)
        msg = f"every goal already holds: {shown}; propose goals that are not yet true"
        return GoalParse(GoalStatus.ALREADY_TRUE, (), (msg,), source)
    notes = tuple(f"dropped {_show_lit(g)}: it already holds" for g in true)
    kept = tuple(g for g in goals if g not in true)
    return GoalParse(GoalStatus.OK, kept, (), source, notes)


# ---------------------------------------------------------------------------------------------
# choosing the part of the answer to read


def _answer_region(text: str) -> str:
    if text.lstrip().startswith("{"):
        return text
    blocks = _code_blocks(text)
    starts = [b[0] for b in blocks]
    markers = [m for m in _MARKER.finditer(text) if not _inside(blocks, starts, m.start())]
    if markers and (not blocks or markers[-1].start() >= blocks[-1][1]):
        return text[markers[-1].end() :]
    if blocks:
        content = text[blocks[-1][2] : blocks[-1][3]]
        return content if content.lstrip().startswith("{") else _after_marker(content)
    return text


def _inside(blocks: Sequence[tuple[int, int, int, int]], starts: list[int], at: int) -> bool:
    k = bisect.bisect_right(starts, at) - 1
    return k >= 0 and at < blocks[k][1]


def _after_marker(text: str) -> str:
    markers = list(_MARKER.finditer(text))
    return text[markers[-1].end() :] if markers else text


def _code_blocks(text: str) -> list[tuple[int, int, int, int]]:
    """(span start, span end, content start, content end) of each fenced block, in order."""
    fences = [m.start() for m in _FENCE.finditer(text)]
    blocks = []
    for k in range(0, len(fences), 2):
        opened = fences[k]
        closed = fences[k + 1] if k + 1 < len(fences) else len(text)
        start = opened + 3
        newline = text.find("\n", start, closed)
        if newline >= 0 and _TAG.match(text[start:newline].strip()):
            start = newline + 1
        blocks.append((opened, min(closed + 3, len(text)), start, closed))
    return blocks


def _candidates(region: str) -> tuple[str, list[_Item]]:
    start = _json_start(region)
    if start is not None:
        return _json_candidates(region, start)
    return _sexpr_candidates(region)


def _json_start(region: str) -> int | None:
    stripped = region.lstrip()
    if stripped.startswith("{"):
        return len(region) - len(stripped)
    found = list(_JSON_GOALS.finditer(region))
    return found[-1].start() if found else None


# ---------------------------------------------------------------------------------------------
# s-expressions


def _tokens(text: str) -> Iterable[tuple[str, int]]:
    """``(``, ``)`` and names (markdown ``*``/backticks stripped) with their offsets."""
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
        elif c == ";":
            while i < n and text[i] != "\n":
                i += 1
        elif c in "()":
            yield c, i
            i += 1
        else:
            start = i
            while i < n and not text[i].isspace() and text[i] not in "();":
                i += 1
            name = text[start:i].strip("`*").lower()
            if name:
                yield name, start


def _read(text: str) -> tuple[tuple[_Node, ...], str | None]:
    """Top-level nodes of ``text``, or an error; iterative and depth-bounded."""
    stack: list[tuple[int, list[_Node]]] = []
    top: list[_Node] = []
    for tok, at in _tokens(text):
        if tok == "(":
            if len(stack) >= MAX_DEPTH:
                return (
                    (),
                    f"parentheses nested deeper than {MAX_DEPTH} levels at {_where(text, at)}",
                )
            stack.append((at, []))
        elif tok == ")":
            if not stack:
                return (), f"unbalanced parentheses: ')' at {_where(text, at)} has no matching '('"
            opened, items = stack.pop()
            (stack[-1][1] if stack else top).append(_List(tuple(items), opened, at + 1))
        else:
            (stack[-1][1] if stack else top).append(tok)
    if stack:
        at = stack[-1][0]
        return (), f"unbalanced parentheses: '(' at {_where(text, at)} is never closed"
    return tuple(top), None


def _where(text: str, at: int) -> str:
    line = text.count("\n", 0, at) + 1
    col = at - (text.rfind("\n", 0, at) + 1) + 1
    return f"line {line}, column {col}"


def _sexpr_candidates(region: str) -> tuple[str, list[_Item]]:
    nodes, error = _read(region)
    if error is not None:
        return region.strip(), [_Issue(GoalStatus.SYNTAX, error)]
    lists = [_unwrap_goal(n) for n in nodes if isinstance(n, _List)]
    ands = [n for n in lists if _head(n) == "and"]
    if ands:
        last = ands[-1]
        if len(last.items) == 1:
            return _slice(region, last), [_Issue(GoalStatus.EMPTY, "(and) holds no goal literals")]
        return _slice(region, last), [_from_node(n) for n in last.items[1:]]
    if not lists:
        found = f"in '{_excerpt(region)}'" if region.strip() else "(the answer is empty)"
        msg = f"no goal literals found {found}; write the goals as (and (predicate object ...) ...)"
        return region.strip(), [_Issue(GoalStatus.EMPTY, msg)]
    return region.strip(), [_from_node(n) for n in lists]


def _slice(region: str, node: _List) -> str:
    return region[node.start : node.end]


def _unwrap_goal(node: _List) -> _List:
    if _head(node) == ":goal" and len(node.items) == 2 and isinstance(node.items[1], _List):
        return node.items[1]
    return node


def _head(node: _List) -> str | None:
    return node.items[0] if node.items and isinstance(node.items[0], str) else None


def _from_node(node: _Node) -> _Item:
    if isinstance(node, str):
        msg = f"expected a literal in parentheses inside (and ...), found '{_show(node)}'"
        return _Issue(GoalStatus.SYNTAX, msg)
    if _head(node) != "not":
        return _atom(node)
    if len(node.items) != 2 or not isinstance(node.items[1], _List):
        msg = f"(not ...) takes exactly one literal in parentheses: {_render(node)}"
        return _Issue(GoalStatus.SYNTAX, msg)
    inner = _atom(node.items[1])
    return Not(inner) if isinstance(inner, Atom) else inner


def _atom(node: _List) -> Atom | _Issue:
    shown = _render(node)
    if not node.items:
        return _Issue(GoalStatus.SYNTAX, "empty parentheses '()' are not a goal literal")
    head = node.items[0]
    if isinstance(head, _List):
        msg = f"a literal must start with a predicate name, not a list: {shown}"
        return _Issue(GoalStatus.SYNTAX, msg)
    return _atom_from_names(head, node.items[1:], shown)


def _atom_from_names(head: str, args: Sequence[_Node], shown: str) -> Atom | _Issue:
    problem = _head_problem(head, shown)
    if problem is None:
        problem = next((p for p in (_arg_problem(a, shown) for a in args) if p), None)
    if problem is not None:
        return _Issue(GoalStatus.SYNTAX, problem)
    return Atom(head, tuple(a for a in args if isinstance(a, str)))


def _head_problem(head: str, shown: str) -> str | None:
    only = "give only (predicate object ...) or (not (predicate object ...))"
    if not head:
        return f"empty predicate name in {shown}"
    if head == "not":
        return f"double negation is not allowed: {shown}; {only}"
    if head == "and":
        return f"nested (and ...) is not allowed: {shown}; give one flat (and ...)"
    if head in CONNECTIVES:
        return f"'{head}' is not allowed in goals: {shown}; {only}"
    if head.startswith("?"):
        return f"variable '{_show(head)}' in predicate position: {shown}"
    if head.startswith(":"):
        return f"keyword '{_show(head)}' is not a goal literal: {shown}; {only}"
    if _NUMBER.match(head):
        return f"number '{_show(head)}' in predicate position: {shown}; {only}"
    return None


def _arg_problem(arg: _Node, shown: str) -> str | None:
    if isinstance(arg, _List):
        return f"nested formula {_render(arg)} inside {shown}: arguments must be object names"
    if not arg:
        return f"empty object name in {shown}"
    if arg.startswith("?"):
        return f"variable '{_show(arg)}' in {shown}: goals must name objects, not variables"
    if _NUMBER.match(arg):
        return f"number '{_show(arg)}' in {shown}: arguments must be object names"
    return None


# ---------------------------------------------------------------------------------------------
# JSON


def _json_candidates(region: str, start: int) -> tuple[str, list[_Item]]:
    if _json_too_deep(region, start):
        msg = f"invalid JSON: nested deeper than {MAX_DEPTH} levels"
        return region[start:].strip(), [_Issue(GoalStatus.SYNTAX, msg)]
    try:
        data, end = json.JSONDecoder().raw_decode(region, start)
    except (ValueError, RecursionError) as e:
        msg = f"invalid JSON: {_show(str(e), 120)}"
        return region[start:].strip(), [_Issue(GoalStatus.SYNTAX, msg)]
    source = region[start:end]
    if not isinstance(data, dict):
        msg = f"expected a JSON object with a 'goals' list, found a JSON {_json_type(data)}"
        return source, [_Issue(GoalStatus.SYNTAX, msg)]
    keys = [k for k in data if k.lower() == "goals"]
    if not keys:
        return source, [_Issue(GoalStatus.SYNTAX, "the JSON object has no 'goals' list")]
    goals = data[keys[-1]]
    if not isinstance(goals, list):
        msg = f"'goals' must be a JSON array, found a JSON {_json_type(goals)}"
        return source, [_Issue(GoalStatus.SYNTAX, msg)]
    if not goals:
        return source, [_Issue(GoalStatus.EMPTY, "the 'goals' list is empty")]
    return source, [_json_item(i, g) for i, g in enumerate(goals, 1)]


def _json_too_deep(text: str, start: int) -> bool:
    depth, in_string, escaped = 0, False, False
    for c in text[start:]:
        if in_string:
            escaped, in_string = (False, True) if escaped else (c == "\\", c != '"')
        elif c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                return True
        elif c in "]}":
            depth -= 1
            if depth <= 0:
                return False
    return False


def _json_item(i: int, goal: Any) -> _Item:
    if isinstance(goal, str):
        return _json_string_item(i, goal)
    if isinstance(goal, dict):
        return _json_object_item(i, goal)
    msg = (
        f'goal {i} must be a string like "(on a b)" or an object with predicate/args/negated, '
        f"found a JSON {_json_type(goal)}"
    )
    return _Issue(GoalStatus.SYNTAX, msg)


def _json_string_item(i: int, goal: str) -> _Item:
    nodes, error = _read(goal)
    if error is not None:
        return _Issue(GoalStatus.SYNTAX, f"goal {i} '{_excerpt(goal)}': {error}")
    if len(nodes) != 1 or not isinstance(nodes[0], _List):
        msg = f"goal {i} must be exactly one literal in parentheses, got '{_excerpt(goal)}'"
        return _Issue(GoalStatus.SYNTAX, msg)
    return _from_node(nodes[0])


def _json_object_item(i: int, goal: dict[str, Any]) -> _Item:
    pred = goal.get("predicate")
    args = goal.get("args", [])
    negated = goal.get("negated", False)
    if not isinstance(pred, str) or not pred.strip():
        return _Issue(GoalStatus.SYNTAX, f"goal {i}: 'predicate' must be a non-empty string")
    name = pred.strip().lower()
    if not isinstance(args, list) or not all(isinstance(a, str) for a in args):
        msg = f"goal {i} ('{_show(name)}'): 'args' must be a list of object names (strings)"
        return _Issue(GoalStatus.SYNTAX, msg)
    if not isinstance(negated, bool):
        msg = f"goal {i} ('{_show(name)}'): 'negated' must be true or false"
        return _Issue(GoalStatus.SYNTAX, msg)
    names = [a.strip().lower() for a in args]
    shown = "(" + " ".join(_show(n) for n in (name, *names)) + ")"
    atom = _atom_from_names(name, names, shown)
    return Not(atom) if negated and isinstance(atom, Atom) else atom


def _json_type(value: object) -> str:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, dict):
        return "object"
    if isinstance(value, list):
        return "array"
    return "string" if isinstance(value, str) else "null"


# ---------------------------------------------------------------------------------------------
# vocabulary checks


def _check(lit: Literal, vocab: Vocabulary, objects: frozenset[str]) -> list[_Issue]:
    atom = lit.arg if isinstance(lit, Not) else lit
    if not isinstance(atom, Atom):  # pragma: no cover - the readers only build Not(Atom)
        return [_Issue(GoalStatus.SYNTAX, f"not a goal literal: {lit}")]
    shown, pred = _show_lit(lit), atom.predicate
    allowed = vocab.predicates.get(pred)
    if allowed is None:
        msg = (
            f"unknown predicate '{_show(pred)}'{_ascii_hint(pred)} in {shown}; "
            f"goal predicates: {vocab.signature()}"
        )
        return [_Issue(GoalStatus.UNKNOWN_PREDICATE, msg)]
    if len(atom.args) != len(allowed):
        n = len(allowed)
        msg = f"'{pred}' takes {n} argument{'' if n == 1 else 's'}, got {len(atom.args)} in {shown}"
        return [_Issue(GoalStatus.ARITY, msg)]
    issues = []
    for i, (arg, ok) in enumerate(zip(atom.args, allowed, strict=True), 1):
        if arg in ok:
            continue
        if arg in objects:
            msg = f"'{arg}' cannot be argument {i} of '{pred}' in {shown}; allowed: {_listing(ok)}"
            issues.append(_Issue(GoalStatus.WRONG_KIND, msg))
        else:
            msg = (
                f"unknown object '{_show(arg)}'{_ascii_hint(arg)} in {shown}; "
                f"allowed as argument {i} of '{pred}': {_listing(ok)}"
            )
            issues.append(_Issue(GoalStatus.UNKNOWN_OBJECT, msg))
    return issues


# ---------------------------------------------------------------------------------------------
# rendering for messages (every shown name is escaped and bounded)


def _show(name: str, limit: int = 40) -> str:
    shown = "".join(c if c.isprintable() else f"\\u{ord(c):04x}" for c in name[:limit])
    return shown + ("..." if len(name) > limit else "")


def _ascii_hint(name: str) -> str:
    odd = next((c for c in name if not c.isascii()), None)
    if odd is None:
        return ""
    return f" (contains the non-ASCII character U+{ord(odd):04X}; use plain ASCII names)"


def _excerpt(text: str, limit: int = 60) -> str:
    return _show(" ".join(text.split()), limit)


def _render(node: _Node, limit: int = 100) -> str:
    text = _render_full(node)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _render_full(node: _Node) -> str:
    if isinstance(node, str):
        return _show(node)
    return "(" + " ".join(_render_full(n) for n in node.items) + ")"


def _show_lit(lit: Literal) -> str:
    if isinstance(lit, Not):
        inner = lit.arg if isinstance(lit.arg, Atom) else Atom("?")
        return f"(not {_show_lit(inner)})"
    return "(" + " ".join(_show(n) for n in (lit.predicate, *lit.args)) + ")"


def _listing(names: Iterable[str], limit: int = 20) -> str:
    ordered = sorted(names)
    more = f", ... ({len(ordered) - limit} more)" if len(ordered) > limit else ""
    return ", ".join(ordered[:limit]) + more
