"""Text that is safe to show or write: secrets redacted, control characters and lone surrogates
escaped, Markdown fences that cannot be broken out of.

Everything that reaches the terminal, a log or a file from outside (an LLM server's answers and
error bodies, a user's file) goes through :func:`redact` and, where it is written, through
:func:`printable`. This is the one redaction helper: backends, the CLI's error line and the log
handler all call it.
"""

from __future__ import annotations

import json
import logging
import os
import re
import urllib.parse
from collections.abc import Iterable

REDACTED = "[REDACTED]"
SECRET_ENV = ("OPENAI_API_KEY", "LLMPAS_API_KEY")  # environment variables holding API keys
MIN_SECRET = 6  # shorter "secrets" (e.g. a dummy key "x") would redact ordinary text

# credentials that look like credentials, whoever's they are: bearer tokens, OpenAI-style keys,
# ``api_key=...`` pairs
_PATTERNS = re.compile(
    r"(?i)(?P<bearer>\bbearer\s+)[^\s\"',;}]+"
    r"|\bsk-[A-Za-z0-9_\-]{8,}"
    r"|(?P<pair>\b(?:api[_-]?key|authorization|x-api-key)\b[\"']?\s*[:=]\s*[\"']?)[^\s\"',;}]+"
)
_UNPRINTABLE = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u2028\u2029\ud800-\udfff]")


def env_secrets() -> tuple[str, ...]:
    """The API keys set in this process's environment (:data:`SECRET_ENV`)."""
    return tuple(v for name in SECRET_ENV if (v := os.environ.get(name)))


def _variants(secret: str) -> set[str]:
    """A secret as it may be echoed back: verbatim, JSON-escaped, percent-encoded."""
    return {secret, json.dumps(secret)[1:-1], urllib.parse.quote(secret, safe="")}


def redact(text: str, secrets: Iterable[str] = ()) -> str:
    """``text`` with every given secret (and anything shaped like a credential) replaced by
    ``[REDACTED]``."""
    out = str(text)
    forms = {v for s in secrets if s and len(s) >= MIN_SECRET for v in _variants(s)}
    for form in sorted(forms, key=len, reverse=True):
        out = out.replace(form, REDACTED)
    return _PATTERNS.sub(_credential, out)


def _credential(match: re.Match[str]) -> str:
    return (match.group("bearer") or match.group("pair") or "") + REDACTED


def printable(text: str, keep_newlines: bool = True) -> str:
    """``text`` with control characters (terminal escapes included), line and paragraph
    separators and lone surrogates written as ``\\xNN`` / ``\\uNNNN`` escapes. Newlines and tabs
    are kept when ``keep_newlines``."""

    def escape(m: re.Match[str]) -> str:
        c = ord(m.group())
        return f"\\x{c:02x}" if c < 0x100 else f"\\u{c:04x}"

    out = str(text)
    if not keep_newlines:
        out = out.replace("\n", "\\n").replace("\r", "\\r").replace("\t", "\\t")
    return _UNPRINTABLE.sub(escape, out)


def one_line(text: str, limit: int = 200) -> str:
    """``text`` as one printable line of at most ``limit`` characters."""
    line = " ".join(printable(text, keep_newlines=True).split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


def fenced(text: str, info: str = "text") -> list[str]:
    """A Markdown code block holding ``text`` verbatim: the fence is one backtick longer than
    any run of backticks in ``text``, so nothing inside can close it."""
    longest = max((len(run) for run in re.findall(r"`+", text)), default=0)
    fence = "`" * max(3, longest + 1)
    return [fence + info, printable(text), fence]


class RedactingFilter(logging.Filter):
    """A logging filter that redacts ``secrets`` (and credential-shaped text) from every record
    it sees (attach it to a handler)."""

    def __init__(self, secrets: Iterable[str] = ()) -> None:
        super().__init__()
        self.secrets = tuple(secrets)

    def filter(self, record: logging.LogRecord) -> bool:
        record.msg = printable(redact(record.getMessage(), self.secrets))
        record.args = None
        if record.exc_info:  # the traceback's text is formatted later: pre-format and redact
            text = logging.Formatter().formatException(record.exc_info)
            record.exc_info = None
            record.exc_text = None
            record.msg += "\n" + redact(text, self.secrets)
        return True


__all__ = [
    "REDACTED",
    "SECRET_ENV",
    "RedactingFilter",
    "env_secrets",
    "fenced",
    "one_line",
    "printable",
    "redact",
]
