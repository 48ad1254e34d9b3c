"""A small s-expression reader with source positions, for PDDL and stream files.

Symbols are lower-cased (PDDL is case-insensitive; ``Sym.written`` keeps the spelling); ``;``
starts a comment that runs to the end of the line, wherever it stands.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field

from llmpas.language.language_errors import PddlSyntaxError


@dataclass(frozen=True, slots=True)
class Pos:
    filename: str
    line: int
    col: int

    def error(self, message: str) -> PddlSyntaxError:
        return PddlSyntaxError(self.filename, self.line, self.col, message)


@dataclass(frozen=True, slots=True)
class Sym:
    """An atom of the text: a name, a ``?variable``, a ``:keyword`` or a number."""

    text: str
    pos: Pos
    raw: str = field(default="", compare=False)  # as written (``text`` is lower-cased)

    def __str__(self) -> str:
        return self.text

    @property
    def written(self) -> str:
        return self.raw or self.text


@dataclass(frozen=True, slots=True)
class SList:
    """A parenthesised list."""

    items: tuple[SExpr, ...]
    pos: Pos

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self) -> Iterator[SExpr]:
        return iter(self.items)

    def __getitem__(self, i: int) -> SExpr:
        return self.items[i]

    def head(self) -> str | None:
        """The lower-case first symbol, or None when the list is empty or starts with a list."""
        if self.items and isinstance(self.items[0], Sym):
            return self.items[0].text
        return None


SExpr = Sym | SList


# a newline | other whitespace | a comment | a parenthesis | an atom
_TOKEN = re.compile(r"(\n)|[^\S\n]+|;[^\n]*|([()])|([^\s();]+)")
MAX_DEPTH = 100  # nesting levels of parentheses: deeper text is refused as it is read


def _tokens(text: str, filename: str) -> Iterator[tuple[str, Pos]]:
    line, line_start = 1, 0
    for m in _TOKEN.finditer(text):
        if m.group(1):
            line, line_start = line + 1, m.end()
        elif m.lastindex:
            yield m.group(m.lastindex), Pos(filename, line, m.start() - line_start + 1)


def parse_all(text: str, filename: str = "<string>") -> tuple[SExpr, ...]:
    """Read every top-level expression of ``text``."""
    stack: list[tuple[Pos, list[SExpr]]] = []
    top: list[SExpr] = []
    for tok, pos in _tokens(text, filename):
        if tok == "(":
            if len(stack) >= MAX_DEPTH:
                raise pos.error(f"parentheses nested deeper than {MAX_DEPTH} levels")
            stack.append((pos, []))
        elif tok == ")":
            if not stack:
                raise pos.error("unexpected ')' with no matching '('")
            opened, items = stack.pop()
            node = SList(tuple(items), opened)
            (stack[-1][1] if stack else top).append(node)
        else:
            sym = Sym(tok.lower(), pos, tok)
            (stack[-1][1] if stack else top).append(sym)
    if stack:
        raise stack[-1][0].error("'(' is never closed")
    return tuple(top)


def parse_one(text: str, filename: str = "<string>") -> SList:
    """Read a file that holds exactly one parenthesised expression."""
    exprs = parse_all(text, filename)
    if not exprs:
        raise Pos(filename, 1, 1).error("empty file: expected '(define ...)'")
    first = exprs[0]
    if not isinstance(first, SList):
        raise first.pos.error(f"expected '(define ...)', found '{first.text}'")
    if len(exprs) > 1:
        raise exprs[1].pos.error("unexpected text after the end of the definition")
    return first


def parse_definition(text: str, kind: str, filename: str) -> tuple[SList, str, tuple[SExpr, ...]]:
    """Read ``(define (KIND NAME) section...)``: the whole list, the name and the sections."""
    root = parse_one(text, filename)
    if root.head() != "define" or len(root) < 2:
        raise root.pos.error(f"expected '(define ({kind} NAME) ...)'")
    header = expect_list(root[1], f"'({kind} NAME)'")
    if header.head() != kind or len(header) != 2:
        raise header.pos.error(f"expected '({kind} NAME)'")
    return root, expect_sym(header[1], f"a {kind} name").text, root.items[2:]


def expect_list(e: SExpr, what: str) -> SList:
    if not isinstance(e, SList):
        raise e.pos.error(f"expected {what} in parentheses, found '{e.text}'")
    return e


def expect_sym(e: SExpr, what: str) -> Sym:
    if not isinstance(e, Sym):
        raise e.pos.error(f"expected {what}, found a parenthesised list")
    return e


def keyword_sections(
    items: tuple[SExpr, ...], what: str
) -> Iterator[tuple[Sym, tuple[SExpr, ...]]]:
    """Split ``:key v1 v2 :key2 v3`` into (key, values) pairs."""
    i = 0
    while i < len(items):
        key = items[i]
        if not isinstance(key, Sym) or not key.text.startswith(":"):
            raise items[i].pos.error(f"expected a ':keyword' in {what}")
        j = i + 1
        while j < len(items) and not (
            isinstance(items[j], Sym) and items[j].text.startswith(":")  # type: ignore[union-attr]
        ):
            j += 1
        yield key, items[i + 1 : j]
        i = j
