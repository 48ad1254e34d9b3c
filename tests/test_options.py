"""Option value types: refused while the command line is parsed."""

from __future__ import annotations

import argparse

import pytest

from llmpas.options import MAX_SECONDS, bounded_int, positive_float, positive_int, seed


@pytest.mark.parametrize("text", ["nan", "inf", "-inf", "-1", "0", "", "abc", "1e309", "1e9"])
def test_positive_float_refuses(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        positive_float(text)


@pytest.mark.parametrize(("text", "value"), [("0.5", 0.5), ("60", 60.0), ("1e-3", 0.001)])
def test_positive_float_accepts(text: str, value: float) -> None:
    assert positive_float(text) == value
    assert positive_float(str(MAX_SECONDS)) == MAX_SECONDS


@pytest.mark.parametrize("text", ["0", "-3", "2.5", "1e3", "1_000", "x", "9" * 5000])
def test_positive_int_refuses(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        positive_int(text)


def test_bounded_int_bounds_are_inclusive() -> None:
    t = bounded_int(1, 8)
    assert (t("1"), t("8"), t(" 3 ")) == (1, 8, 3)
    with pytest.raises(argparse.ArgumentTypeError, match="from 1 to 8, got '9'"):
        t("9")
    assert seed("0") == 0
    with pytest.raises(argparse.ArgumentTypeError):
        seed("-1")


def test_argparse_reports_the_option() -> None:
    p = argparse.ArgumentParser(exit_on_error=False)
    p.add_argument("--max-time", type=positive_float)
    with pytest.raises(argparse.ArgumentError, match="--max-time"):
        p.parse_args(["--max-time", "nan"])
