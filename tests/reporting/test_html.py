"""The one escaping rule of the web reports."""

from __future__ import annotations

import html
import re

from hypothesis import given
from hypothesis import strategies as st

from llmpas.reporting.html import Markup, clean, href, tag, text, void

# anything: every code point, lone surrogates included
ANY_TEXT = st.text(st.characters(min_codepoint=0, max_codepoint=0x10FFFF))


def test_terminal_escapes_surrogates_and_direction_marks_become_visible_text() -> None:
    out = clean("a\x1b[31mred\x1b[0m\x07\tb\r\nc\ud800\u202eevil\x9b")
    assert out == "a\\x1b[31mred\\x1b[0m\\x07\tb\nc\ufffd<U+202E>evil\\x9b"


def test_markup_in_text_is_escaped_and_markup_built_here_is_not() -> None:
    assert text('<script>alert("x")</script>') == (
        "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;"
    )
    inner = tag("b", "<i>")
    assert tag("p", inner, "<br>") == "<p><b>&lt;i&gt;</b>&lt;br&gt;</p>"
    assert isinstance(inner, Markup)


def test_attribute_values_cannot_close_the_attribute() -> None:
    shown = void("img", src='x" onerror="alert(1)', alt="<a>", class_="c", hidden=True, id=None)
    assert shown == '<img src="x&quot; onerror=&quot;alert(1)" alt="&lt;a&gt;" class="c" hidden>'


def test_relative_links_are_percent_encoded_per_part() -> None:
    assert href("camera/01 look #2?.png") == "camera/01%20look%20%232%3F.png"
    assert href("javascript:alert(1)") == "javascript%3Aalert%281%29"


@given(ANY_TEXT)
def test_escaped_text_has_no_markup_controls_or_surrogates(s: str) -> None:
    out = text(s)
    assert not set(out) & set("<>\"'")
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\ud800-\udfff\u202a-\u202e]", out)
    out.encode("utf-8")  # writable as UTF-8
    assert html.unescape(out) == clean(s)  # the text itself, only made visible
