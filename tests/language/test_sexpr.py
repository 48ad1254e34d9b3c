"""The s-expression reader: structure, lower-casing, comments, positions and syntax errors."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from llmpas.language.language_errors import LanguageError, PddlSyntaxError
from llmpas.language.sexpr import (
    Pos,
    SList,
    Sym,
    expect_list,
    expect_sym,
    keyword_sections,
    parse_all,
    parse_one,
)


def plain(e):
    """An s-expression as nested Python lists of strings (positions dropped)."""
    return e.text if isinstance(e, Sym) else [plain(x) for x in e.items]


def assert_one_line_error(err: PddlSyntaxError, filename: str, line: int, col: int) -> None:
    text = str(err)
    assert "\n" not in text
    assert text == f"{filename}:{line}:{col}: {err.message}"
    assert (err.filename, err.line, err.col) == (filename, line, col)


# ------------------------------------------------------------------------------ reading


def test_nested_structure_and_lower_casing():
    (e,) = parse_all("(Define (Domain BlocksWorld) (:Action Move ?X))")
    assert plain(e) == ["define", ["domain", "blocksworld"], [":action", "move", "?x"]]


def test_numbers_keywords_and_variables_are_symbols():
    (e,) = parse_all("(= (Dist ?A b) 3.5E2 -1 :KEY)")
    assert plain(e) == ["=", ["dist", "?a", "b"], "3.5e2", "-1", ":key"]
    assert all(isinstance(x, Sym) for x in e.items if not isinstance(x, SList))


def test_several_top_level_expressions():
    exprs = parse_all("a (b) (c (d))")
    assert [plain(e) for e in exprs] == ["a", ["b"], ["c", ["d"]]]


def test_comments_anywhere():
    text = """; leading comment (with parens
    (p ; between the head and an argument )))
       ?x;glued to a token
       ; a whole line
       (q)) ; after the last paren
    ; trailing comment without newline"""
    (e,) = parse_all(text)
    assert plain(e) == ["p", "?x", ["q"]]


def test_empty_list_and_head():
    (e,) = parse_all("(() (A b) ((x)))")
    assert isinstance(e, SList)
    assert e[0] == SList((), e[0].pos)
    assert e[0].head() is None
    assert e[1].head() == "a"
    assert e[2].head() is None  # starts with a list
    assert len(e) == 3
    assert [plain(x) for x in e] == [[], ["a", "b"], [["x"]]]


def test_positions_are_one_based_lines_and_columns():
    text = "(define\n  (domain  Foo)\n\t(:predicates (p ?x)))"
    (root,) = parse_all(text, "f.pddl")
    assert root.pos == Pos("f.pddl", 1, 1)
    dom = root[1]
    assert dom.pos == Pos("f.pddl", 2, 3)
    assert dom[0].pos == Pos("f.pddl", 2, 4)
    assert dom[1].pos == Pos("f.pddl", 2, 12)
    preds = root[2]
    assert preds.pos == Pos("f.pddl", 3, 2)  # a tab counts as one column
    assert preds[1][1].pos == Pos("f.pddl", 3, 18)


def test_positions_with_crlf_line_endings_and_comments():
    text = "(a ; c (\r\n  b)\r\n"
    (e,) = parse_all(text, "w.pddl")
    assert plain(e) == ["a", "b"]
    assert e[1].pos == Pos("w.pddl", 2, 3)


def test_parse_one_returns_the_single_definition():
    e = parse_one("  ; header\n(define (domain d)) ; trailer\n; more\n")
    assert plain(e) == ["define", ["domain", "d"]]


# ------------------------------------------------------------------------------ errors


def test_error_is_a_language_error_and_a_value_error():
    with pytest.raises(PddlSyntaxError) as info:
        parse_one("")
    assert isinstance(info.value, LanguageError)
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("text", ["", "   \n\n", "; just a comment\n; another"])
def test_empty_file(text):
    with pytest.raises(PddlSyntaxError) as info:
        parse_one(text, "empty.pddl")
    assert_one_line_error(info.value, "empty.pddl", 1, 1)
    assert "empty file" in info.value.message


def test_unclosed_paren_points_at_the_innermost_open_paren():
    text = "(define (domain d)\n  (:predicates (p ?x)\n"
    with pytest.raises(PddlSyntaxError) as info:
        parse_one(text, "d.pddl")
    assert_one_line_error(info.value, "d.pddl", 2, 3)
    assert info.value.message == "'(' is never closed"


def test_extra_closing_paren():
    text = "(define (domain d))\n  )"
    with pytest.raises(PddlSyntaxError) as info:
        parse_one(text, "d.pddl")
    assert_one_line_error(info.value, "d.pddl", 2, 3)
    assert "unexpected ')'" in info.value.message


def test_extra_closing_paren_inside_a_line():
    with pytest.raises(PddlSyntaxError) as info:
        parse_all("(a))(b)", "x")
    assert_one_line_error(info.value, "x", 1, 4)


def test_garbage_after_the_definition():
    text = "(define (domain d))\n; fine\n  junk (more) ; c"
    with pytest.raises(PddlSyntaxError) as info:
        parse_one(text, "d.pddl")
    assert_one_line_error(info.value, "d.pddl", 3, 3)
    assert "after the end of the definition" in info.value.message


def test_second_definition_is_garbage_too():
    with pytest.raises(PddlSyntaxError) as info:
        parse_one("(define (domain a))\n(define (domain b))", "d.pddl")
    assert_one_line_error(info.value, "d.pddl", 2, 1)


def test_bare_symbol_instead_of_definition():
    with pytest.raises(PddlSyntaxError) as info:
        parse_one("  Foo", "d.pddl")
    assert_one_line_error(info.value, "d.pddl", 1, 3)
    assert "'foo'" in info.value.message


def test_expect_helpers():
    (e,) = parse_all("(a (b))", "h")
    assert expect_list(e, "x") is e
    assert expect_sym(e[0], "x") is e[0]
    with pytest.raises(
        PddlSyntaxError, match=r"^h:1:2: expected a thing in parentheses, found 'a'$"
    ):
        expect_list(e[0], "a thing")
    with pytest.raises(PddlSyntaxError, match=r"^h:1:4: expected a name, found a parenthesised"):
        expect_sym(e[1], "a name")


def test_keyword_sections():
    (e,) = parse_all("(:inputs (?a) :domain (p ?a) (q) :outputs)")
    sections = [(k.text, [plain(v) for v in vs]) for k, vs in keyword_sections(e.items, "s")]
    assert sections == [
        (":inputs", [["?a"]]),
        (":domain", [["p", "?a"], ["q"]]),
        (":outputs", []),
    ]


def test_keyword_sections_needs_a_keyword_first():
    (e,) = parse_all("(stray :inputs (?a))", "k")
    with pytest.raises(PddlSyntaxError, match=r"^k:1:2: expected a ':keyword' in my stream$"):
        list(keyword_sections(e.items, "my stream"))


# ------------------------------------------------------------------------------ properties

SYMBOL_CHARS = "abcXYZ019?:-_.*+<>=/"
symbols = st.text(alphabet=SYMBOL_CHARS, min_size=1, max_size=6)
trees = st.recursive(symbols, lambda kids: st.lists(kids, max_size=4), max_leaves=25)
separators = st.sampled_from([" ", "  ", "\n", "\t", " ; note (with) ;; parens\n", "\r\n"])


def render(tree, seps, out: list[str], places: list[tuple[str, int]]) -> None:
    """Render ``tree`` into ``out``; record (token, offset) of every atom and '('."""

    def sep() -> str:
        return seps[len(out) % len(seps)]

    if isinstance(tree, str):
        places.append((tree, sum(map(len, out))))
        out.append(tree)
        return
    places.append(("(", sum(map(len, out))))
    out.append("(")
    for i, child in enumerate(tree):
        if i:
            out.append(" " + sep())
        render(child, seps, out, places)
    out.append(sep().rstrip(" ") + ")")


def lower(tree):
    return tree.lower() if isinstance(tree, str) else [lower(t) for t in tree]


def flatten(e, acc):
    if isinstance(e, Sym):
        acc.append((e.text, e.pos))
    else:
        acc.append(("(", e.pos))
        for x in e.items:
            flatten(x, acc)
    return acc


def line_col(text: str, offset: int) -> tuple[int, int]:
    before = text[:offset]
    return before.count("\n") + 1, offset - (before.rfind("\n") + 1) + 1


@settings(max_examples=150, deadline=None, database=None)
@given(st.lists(trees, min_size=1, max_size=3), st.lists(separators, min_size=1, max_size=5))
def test_rendered_trees_read_back(forest, seps):
    out: list[str] = []
    places: list[tuple[str, int]] = []
    for tree in forest:
        render(tree, seps, out, places)
        out.append("\n")
    text = "".join(out)
    exprs = parse_all(text, "gen")
    assert [plain(e) for e in exprs] == [lower(t) for t in forest]
    # every atom and every '(' knows where it stands in the text
    read = [x for e in exprs for x in flatten(e, [])]
    assert [tok for tok, _ in read] == [tok.lower() for tok, _ in places]
    for (_, pos), (_, offset) in zip(read, places, strict=True):
        assert (pos.line, pos.col) == line_col(text, offset)
        assert pos.filename == "gen"


@settings(max_examples=100, deadline=None, database=None)
@given(trees.filter(lambda t: isinstance(t, list)), st.integers(min_value=0))
def test_dropping_one_paren_is_a_positioned_error(tree, k):
    out: list[str] = []
    render(tree, [" "], out, [])
    text = "".join(out)
    parens = [i for i, c in enumerate(text) if c in "()"]
    i = parens[k % len(parens)]
    broken = text[:i] + " " + text[i + 1 :]
    with pytest.raises(PddlSyntaxError) as info:
        parse_all(broken, "b")
    err = info.value
    assert "\n" not in str(err)
    # the error points at a parenthesis of the broken text
    assert broken.split("\n")[err.line - 1][err.col - 1] in "()"
