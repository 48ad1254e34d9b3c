"""Reading input files with bounds: regular files only, at most a size cap, UTF-8 only.

Every problem the reader refuses is an :class:`~llmpas.errors.InputError` of one line naming
the file (and the byte offset and line of a bad byte). Nothing blocks or reads without bound:
FIFOs, devices (``/dev/zero``) and folders are refused before a byte is read, and at most
``limit + 1`` bytes are read from a regular file.
"""

from __future__ import annotations

import codecs
import errno
import os
import re
import stat
import tomllib
from pathlib import Path
from typing import Any

from llmpas.errors import InputError

MiB = 1 << 20
PDDL_LIMIT = 8 * MiB  # domain, problem and stream files
TOML_LIMIT = 1 * MiB  # scenario and task files
PYTHON_LIMIT = 4 * MiB  # --bindings files


def _kind(mode: int) -> str | None:
    """What a non-regular file is, or None for a regular file."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _size(limit: int) -> str:
    return f"{limit / MiB:g} MiB" if limit >= MiB else f"{limit} bytes"


def read_bytes(path: str | Path, what: str, limit: int) -> bytes:
    """The bytes of the regular file ``path`` (``what`` says what it is, for messages)."""
    name = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        reason = "no such file" if e.errno == errno.ENOENT else e.strerror or str(e)
        raise InputError(f"{name}: cannot read {what}: {reason}") from None
    try:
        info = os.fstat(fd)
        kind = _kind(info.st_mode)
        if kind is not None:
            raise InputError(f"{name}: expected a {what}, found {kind}")
        if info.st_size > limit:
            raise InputError(
                f"{name}: {what} of {info.st_size} bytes is larger than the {_size(limit)} limit"
            )
        chunks, total = [], 0
        while total <= limit:
            chunk = os.read(fd, min(limit + 1 - total, MiB))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as e:
        raise InputError(f"{name}: cannot read {what}: {e.strerror or e}") from None
    finally:
        os.close(fd)
    if total > limit:  # it grew while we read it
        raise InputError(f"{name}: {what} is larger than the {_size(limit)} limit")
    return b"".join(chunks)


def decode_text(data: bytes, name: str, what: str) -> str:
    """UTF-8 text (a UTF-8 byte-order mark is dropped); UTF-16/32, invalid UTF-8 and NUL bytes
    are refused with the byte offset and line."""
    for bom, enc in (
        (codecs.BOM_UTF32_LE, "UTF-32"),
        (codecs.BOM_UTF32_BE, "UTF-32"),
        (codecs.BOM_UTF16_LE, "UTF-16"),
        (codecs.BOM_UTF16_BE, "UTF-16"),
    ):
        if data.startswith(bom):
            raise InputError(f"{name}: {what} is {enc} text (byte-order mark); save it as UTF-8")
    data = data.removeprefix(codecs.BOM_UTF8)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        bad = data[e.start : e.start + 1].hex()
        raise InputError(
            f"{name}:{_line(data, e.start)}: {what} is not UTF-8 text: "
            f"byte 0x{bad} at byte offset {e.start}"
        ) from None
    nul = data.find(b"\0")
    if nul >= 0:
        hint = " (UTF-16 text?)" if len(data) >= 8 and data.count(b"\0") * 3 >= len(data) else ""
        raise InputError(
            f"{name}:{_line(data, nul)}: {what} holds a NUL byte at byte offset "
            f"{nul}{hint}; expected UTF-8 text"
        )
    return text


def _line(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def read_text(path: str | Path, what: str, limit: int) -> str:
    """The UTF-8 text of the regular file ``path``, of at most ``limit`` bytes."""
    return decode_text(read_bytes(path, what, limit), str(path), what)


# TOML strings and comments (left out before looking for long dotted keys)
_TOML_SKIP = re.compile(
    r'"""(?:[^\\]|\\.)*?"""|\'\'\'.*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*', re.S
)
MAX_TOML_KEY_PARTS = 16
# a dotted key of more than MAX_TOML_KEY_PARTS parts (tomllib takes quadratic time and memory)
_LONG_KEY = re.compile(r"(?<![\w-])(?:[\w-]++\s*+\.\s*+){" + str(MAX_TOML_KEY_PARTS) + ",}")


def parse_toml(text: str, name: str) -> dict[str, Any]:
    """The table of TOML ``text``; errors name the file (and line and column)."""
    stripped = _TOML_SKIP.sub(lambda m: "s" if m.group().startswith(("'", '"')) else "", text)
    if _LONG_KEY.search(stripped):
        raise InputError(f"{name}: a TOML key has more than {MAX_TOML_KEY_PARTS} dotted parts")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{name}: invalid TOML: {e}") from None
    except RecursionError:
        raise InputError(f"{name}: TOML arrays or tables nested too deeply") from None


def read_toml(path: str | Path, what: str, limit: int = TOML_LIMIT) -> dict[str, Any]:
    """The table of the TOML file ``path``: read as :func:`read_text` does, then parsed."""
    return parse_toml(read_text(path, what, limit), str(path))


__all__ = [
    "PDDL_LIMIT",
    "PYTHON_LIMIT",
    "TOML_LIMIT",
    "decode_text",
    "parse_toml",
    "read_bytes",
    "read_text",
    "read_toml",
]
