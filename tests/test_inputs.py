"""Bounded reading of input files: regular UTF-8 files under a cap, and safe TOML."""

from __future__ import annotations

import codecs
import os
import threading
from pathlib import Path

import pytest

from llmpas.errors import InputError
from llmpas.inputs import parse_toml, read_bytes, read_text


def test_reads_utf8_and_drops_a_byte_order_mark(tmp_path: Path) -> None:
    f = tmp_path / "a.pddl"
    f.write_bytes(codecs.BOM_UTF8 + "(define (domain é))".encode())
    assert read_text(f, "PDDL file", 100) == "(define (domain é))"


def test_the_cap_is_exact(tmp_path: Path) -> None:
    f = tmp_path / "a.pddl"
    f.write_bytes(b"x" * 10)
    assert read_bytes(f, "PDDL file", 10) == b"x" * 10
    with pytest.raises(InputError, match=r"a\.pddl: PDDL file of 10 bytes is larger than"):
        read_bytes(f, "PDDL file", 9)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ("(a)".encode("utf-16"), "UTF-16 text"),
        ("(a)".encode("utf-32"), "UTF-32 text"),
        (b"(a)\n(b \xff)", r"f\.txt:2: t is not UTF-8 text: byte 0xff at byte offset 7"),
        (b"(a\x00)", r"f\.txt:1: t holds a NUL byte at byte offset 2; expected UTF-8"),
        ("(define)".encode("utf-16-le"), r"NUL byte at byte offset 1 \(UTF-16 text\?\)"),
        (b"\xed\xa0\x80", "not UTF-8 text: byte 0xed"),  # an encoded surrogate
    ],
)
def test_encodings_other_than_utf8_are_named(tmp_path: Path, data: bytes, message: str) -> None:
    f = tmp_path / "f.txt"
    f.write_bytes(data)
    with pytest.raises(InputError, match=message):
        read_text(f, "t", 1000)


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.pddl"
    os.mkfifo(fifo)
    errors: list[Exception] = []

    def read() -> None:
        try:
            read_text(fifo, "PDDL file", 100)
        except InputError as e:
            errors.append(e)

    t = threading.Thread(target=read, daemon=True)
    t.start()
    t.join(30)
    assert not t.is_alive(), "reading a FIFO blocked"
    assert "pipe.pddl: expected a PDDL file, found a FIFO" in str(errors[0])


@pytest.mark.parametrize(
    ("path", "message"),
    [("/dev/zero", "found a device"), ("/", "found a folder"), ("no/such", "no such file")],
)
def test_non_regular_and_missing_files(path: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        read_text(path, "PDDL file", 100)


def test_toml_errors_name_the_file() -> None:
    with pytest.raises(InputError, match=r"s\.toml: invalid TOML: .*line 1"):
        parse_toml("a = = 1", "s.toml")
    with pytest.raises(InputError, match="nested too deeply"):
        parse_toml("x = " + "[" * 50_000 + "]" * 50_000, "s.toml")
    with pytest.raises(InputError, match="more than 16 dotted parts"):
        parse_toml("a" + ".a" * 20 + " = 1", "s.toml")


def test_toml_dots_in_values_strings_and_comments_are_not_keys() -> None:
    dotted = ".".join(["x"] * 40)
    text = (
        f"a = \"{dotted}\"\nb = '{dotted}'\n# {dotted}\nc = [1.5, 2.5]\n"
        f'd = """\n{dotted}\n"""\ne.f.g = 1\n'
    )
    data = parse_toml(text, "s.toml")
    assert data["a"] == dotted and data["e"] == {"f": {"g": 1}} and data["c"] == [1.5, 2.5]
