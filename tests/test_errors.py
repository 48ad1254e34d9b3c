"""One-line error messages and the exit statuses they map to."""

from __future__ import annotations

import pytest

from llmpas.errors import (
    EXIT_CODES_HELP,
    ExitCode,
    InputError,
    LlmpasError,
    OutputError,
    PlannerError,
    UsageError,
    one_line,
)


def test_one_line_escapes_what_would_break_the_line_or_the_terminal() -> None:
    text = "a.pddl:1:2: bad\nnext\r\x1b[2J\x07 \u2028 \udcff end"
    line = one_line(text)
    assert "\n" not in line and "\r" not in line and "\x1b" not in line and "\x07" not in line
    assert line == "a.pddl:1:2: bad\\nnext\\r\\x1b[2J\\x07 \\u2028 \\udcff end"
    line.encode("utf-8")  # no lone surrogate left


def test_one_line_keeps_both_ends_of_a_long_message() -> None:
    text = "file.pddl:3:4: found '" + "x" * 10_000 + "' at the end"
    line = one_line(text, limit=200)
    assert len(line) <= 200
    assert line.startswith("file.pddl:3:4: found 'xx") and line.endswith("' at the end")


def test_printable_text_is_unchanged() -> None:
    assert one_line("naïve [bold]café[/] – ok") == "naïve [bold]café[/] – ok"


@pytest.mark.parametrize(
    ("error", "code"),
    [
        (UsageError("x"), ExitCode.USAGE),
        (InputError("x"), ExitCode.INPUT),
        (PlannerError("x"), ExitCode.PLANNER),
        (OutputError("x"), ExitCode.IO),
        (LlmpasError("x"), ExitCode.INTERNAL),
    ],
)
def test_each_class_has_its_exit_status(error: LlmpasError, code: ExitCode) -> None:
    assert error.code is code
    assert f"{int(code)} " in EXIT_CODES_HELP


def test_input_errors_are_value_errors_for_existing_callers() -> None:
    with pytest.raises(ValueError, match="bad"):
        raise InputError("bad")


def test_exit_statuses_are_distinct() -> None:
    assert len({int(c) for c in ExitCode}) == len(ExitCode)
