"""Small explicit HTML builders for the reports, and the one escaping rule they all use.

Every string that comes from a file or an LLM goes through :func:`text`: HTML-escaped, and with
control characters (terminal escapes included), bidirectional overrides and lone surrogates
replaced by visible stand-ins, so that no markup, script or escape sequence gets through.
Markup is built only by :func:`tag`, whose content is escaped unless it is :class:`Markup`.
"""

from __future__ import annotations

import html
import re
from collections.abc import Iterable
from urllib.parse import quote

_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")
_INVISIBLE = re.compile(r"[\u200b-\u200f\u202a-\u202e\u2060-\u2069\ufeff\ufff9-\ufffb]")
_SURROGATE = re.compile(r"[\ud800-\udfff]")


class Markup(str):
    """HTML built here (never from outside text): inserted as is."""

    __slots__ = ()


def clean(value: object) -> str:
    """``value`` as text with nothing that could act: C0/C1 controls (terminal escapes) are
    shown as ``\\xNN``, invisible and direction marks as ``<U+202E>``, lone surrogates as U+FFFD.
    Newlines and tabs stay."""
    s = value if isinstance(value, str) else str(value)
    s = _SURROGATE.sub("\ufffd", s).replace("\r\n", "\n")
    s = _CONTROL.sub(_control, s)
    return _INVISIBLE.sub(lambda m: f"<U+{ord(m.group()):04X}>", s)


def _control(m: re.Match[str]) -> str:
    return f"\\x{ord(m.group()):02x}"


def text(value: object) -> Markup:
    """``value`` cleaned (:func:`clean`) and HTML-escaped (quotes too)."""
    if isinstance(value, Markup):
        return value
    return Markup(html.escape(clean(value), quote=True))


def join(parts: Iterable[str], sep: str = "") -> Markup:
    """Parts joined; each escaped unless it is :class:`Markup`."""
    return Markup(sep.join(text(p) for p in parts))


def tag(name: str, /, *content: object, **attrs: object) -> Markup:
    """``<name attrs>content</name>``; attribute names end in ``_`` for Python keywords
    (``class_``); a ``None`` or ``False`` attribute is left out, ``True`` is bare."""
    shown = []
    for key, value in attrs.items():
        if value is None or value is False:
            continue
        k = key.rstrip("_").replace("_", "-")
        shown.append(f" {k}" if value is True else f' {k}="{text(value)}"')
    body = "".join(text(c) for c in content)
    return Markup(f"<{name}{''.join(shown)}>{body}</{name}>")


def void(name: str, /, **attrs: object) -> Markup:
    """An element without content (``img``, ``meta``)."""
    return Markup(tag(name, **attrs)[: -len(f"</{name}>")])


def href(relative: str) -> str:
    """A relative file path as a URL path (each part percent-encoded)."""
    return "/".join(quote(part, safe="") for part in relative.split("/"))


def slug(value: object) -> str:
    return re.sub(r"[^a-z0-9]+", "-", clean(value).lower()).strip("-") or "x"


__all__ = ["Markup", "clean", "href", "join", "slug", "tag", "text", "void"]
