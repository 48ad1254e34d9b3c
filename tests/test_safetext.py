"""The one redaction helper and the text escaping every report goes through."""

from __future__ import annotations

import json
import logging
import re
import urllib.parse

import pytest
from hypothesis import given
from hypothesis import strategies as st

from llmpas.safetext import REDACTED, RedactingFilter, fenced, one_line, printable, redact

KEY = "sk-proj-Abc123_def456-GHI789jkl"


@pytest.mark.parametrize(
    "text",
    [
        f"key {KEY} here",
        f"Authorization: Bearer {KEY}",
        json.dumps({"auth": f"Bearer {KEY}"}),
        f"url?api_key={urllib.parse.quote(KEY, safe='')}",
        f"{KEY}{KEY}",
    ],
)
def test_a_given_secret_is_redacted_in_every_form_it_comes_back_in(text: str) -> None:
    out = redact(text, [KEY])
    assert KEY not in out and KEY[8:24] not in out
    assert REDACTED in out


def test_credential_shaped_text_is_redacted_without_knowing_the_secret() -> None:
    for text in ("Bearer abc.def.ghi", "sk-0123456789abcdef", 'x-api-key: "hunter22"'):
        assert REDACTED in redact(text), text
    assert (
        redact("(and (on cube bowl)) (scanned table1)") == "(and (on cube bowl)) (scanned table1)"
    )


def test_tiny_secrets_do_not_redact_ordinary_text() -> None:
    assert redact("a cube on a table", ["a"]) == "a cube on a table"


def test_printable_escapes_controls_and_surrogates_and_keeps_lines() -> None:
    text = "ok\nline\ttab \x1b[31mred\x07 \x00 \ud800 \u2028 \x9b é 漢"
    out = printable(text)
    out.encode("utf-8")  # always encodable
    assert "\n" in out and "\t" in out and "é 漢" in out
    assert "\\x1b[31mred\\x07" in out and "\\x00" in out and "\\ud800" in out
    assert "\\u2028" in out and "\\x9b" in out
    assert "\n" not in printable(text, keep_newlines=False)


@given(st.text())
def test_printable_output_has_no_control_characters_and_encodes(text: str) -> None:
    out = printable(text)
    out.encode("utf-8")
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\ud800-\udfff]", out)


@given(st.text(alphabet=st.sampled_from("`a\n ~")))
def test_no_content_can_close_its_fence(text: str) -> None:
    opening, *body, closing = fenced(text)
    fence = closing
    assert opening == fence + "text"
    assert set(fence) == {"`"} and len(fence) >= 3
    assert not any(line.lstrip().startswith(fence) for line in "\n".join(body).split("\n"))


def test_one_line_is_one_bounded_line() -> None:
    out = one_line("a\nb\r\n\x1b[2J" + "x" * 500, limit=50)
    assert "\n" not in out and len(out) == 50 and out.endswith("...")


def test_the_log_filter_redacts_messages_arguments_and_tracebacks(
    caplog: pytest.LogCaptureFixture,
) -> None:
    log = logging.getLogger("llmpas.test.safetext")
    caplog.handler.addFilter(RedactingFilter([KEY]))
    try:
        log.warning("sent %s", f"Bearer {KEY}")
        try:
            raise ValueError(f"bad key {KEY}")
        except ValueError:
            log.exception("failed")
    finally:
        caplog.handler.filters.clear()
    assert KEY not in caplog.text
    assert caplog.text.count(REDACTED) >= 2
