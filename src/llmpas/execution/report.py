"""Human-readable reports of an execution :class:`~llmpas.execution.executor.Episode`.

:func:`episode_markdown` and :func:`episode_html` (one self-contained page, no external assets)
show the status, summary counts, the anomaly (its sentence and its structured fields), the
timeline and the final believed state. :func:`save_episode` writes them, the episode JSON and,
given the plan's specs, the BehaviorTree.CPP XML of its CSubBTs into a folder, each file
atomically.
"""

from __future__ import annotations

import html
import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from llmpas.execution.anomaly_report import AnomalyReport
from llmpas.execution.csubbt import SubtreeSpec
from llmpas.execution.executor import Episode
from llmpas.execution.export import to_btcpp_files
from llmpas.files import atomic_write
from llmpas.safetext import printable

log = logging.getLogger(__name__)

DEFAULT_TITLE = "Execution episode"


# ---------------------------------------------------------------------------------- content
class _Code(str):
    """A table cell shown as code (atoms, names, values)."""

    __slots__ = ()


@dataclass(frozen=True)
class _Table:
    header: tuple[str, ...]
    rows: Sequence[tuple[str, ...]]


@dataclass
class _Section:
    title: str
    prose: list[str] = field(default_factory=list)
    tables: list[_Table] = field(default_factory=list)
    items: list[str] = field(default_factory=list)
    items_title: str = ""
    note: str = ""
    code: bool = True  # items shown as code


def _summary(ep: Episode) -> _Section:
    rows = [
        ("status", ep.status.value),
        ("subtrees", str(len(ep.subtrees))),
        ("completed plan steps", ", ".join(map(str, ep.completed)) or "none"),
        ("ticks", str(ep.ticks)),
        ("retries (backtracks)", str(ep.retries)),
        ("timeline events", str(len(ep.events))),
    ]
    subtrees = _Table(("#", "subtree"), [(str(i), _Code(s)) for i, s in enumerate(ep.subtrees)])
    prose = [ep.message] if ep.message else []
    return _Section("Summary", prose, [_Table(("quantity", "value"), rows), subtrees])


def _explored(a: AnomalyReport) -> _Table:
    rows = [
        (_Code(dim), _Code(", ".join(vals)), f"{len(vals)} ({len(set(vals))} distinct)")
        for dim, vals in a.explored.items()
    ]
    return _Table(("dimension", "values tried (in order)", "count"), rows)


def _anomaly(a: AnomalyReport) -> _Section:
    fields = [
        ("subtree", _Code(a.subtree)),
        ("action", _Code(f"{a.action}({', '.join(a.args)})")),
        ("plan steps", ", ".join(map(str, a.steps))),
        ("sub-action", _Code(a.sub_action)),
        ("constraint", _Code(str(a.constraint))),
        ("constraint name", _Code(a.constraint_name)),
        ("reason", a.reason),
        ("alternatives explored", str(a.attempts)),
    ]
    fields += [("plan atom", _Code(str(atom))) for atom in a.plan_atoms]
    counts = [(_Code(k), str(n)) for k, n in sorted(a.failures.items())]
    tables = [
        _Table(("field", "value"), fields),
        _explored(a),
        _Table(("constraint", "failures"), counts),
    ]
    observed = list(a.observations) or ["none recorded"]
    return _Section("Anomaly", [a.describe()], tables, observed, "Observations", code=False)


def _timeline(ep: Episode, max_events: int) -> _Section:
    shown = ep.events[:max_events]
    rows = [
        (
            str(i),
            f"{e.t:.3f}",
            _Code(e.node),
            e.status,
            e.message,
            _Code("  ".join(f"{k}={v}" for k, v in e.values.items())),
        )
        for i, e in enumerate(shown)
    ]
    table = _Table(("#", "t (s)", "node", "status", "message", "values"), rows)
    left = len(ep.events) - len(shown)
    note = f"{left} later events not shown (max_events={max_events})." if left > 0 else ""
    return _Section("Timeline", tables=[table], note=note)


def _belief(ep: Episode) -> _Section:
    atoms = sorted(str(a) for a in ep.belief)
    note = "" if atoms else "Nothing is believed."
    return _Section("Final believed state", items=atoms, note=note)


def _sections(ep: Episode, max_events: int) -> list[_Section]:
    out = [_summary(ep)]
    if ep.anomaly is not None:
        out.append(_anomaly(ep.anomaly))
    return [*out, _timeline(ep, max_events), _belief(ep)]


# ---------------------------------------------------------------------------------- markdown
_MD_SPECIAL = re.compile(r"([\\`*_{}\[\]<>|#&~!])")


def _md_text(text: str) -> str:
    return _MD_SPECIAL.sub(r"\\\1", " ".join(text.split()))


def _md_code(text: str, in_table: bool = True) -> str:
    text = " ".join(text.split())
    if not text:
        return ""
    ticks = "`" * (max((len(r) for r in re.findall(r"`+", text)), default=0) + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    if in_table:
        text = text.replace("|", "\\|")
    return f"{ticks}{pad}{text}{pad}{ticks}"


def _md_table(t: _Table) -> list[str]:
    def cell(v: str) -> str:
        return _md_code(v) if isinstance(v, _Code) else _md_text(v)

    lines = ["| " + " | ".join(_md_text(h) for h in t.header) + " |"]
    lines.append("|" + "|".join("---" for _ in t.header) + "|")
    lines += ["| " + " | ".join(map(cell, r)) + " |" for r in t.rows]
    return [*lines, ""]


def _md_section(s: _Section) -> list[str]:
    lines = [f"## {_md_text(s.title)}", ""]
    lines += [line for p in s.prose for line in (f"> {_md_text(p)}", "")]
    for t in s.tables:
        lines += _md_table(t)
    if s.items_title:
        lines += [f"### {_md_text(s.items_title)}", ""]
    show = (lambda i: _md_code(i, in_table=False)) if s.code else _md_text
    lines += [f"- {show(i)}" for i in s.items] + ([""] if s.items else [])
    if s.note:
        lines += [f"*{_md_text(s.note)}*", ""]
    return lines


def episode_markdown(episode: Episode, title: str = DEFAULT_TITLE, max_events: int = 500) -> str:
    """The episode as a Markdown report (GitHub-flavoured tables)."""
    lines = [f"# {_md_text(title)}", "", f"**Status: {_md_text(episode.status.value)}**", ""]
    for s in _sections(episode, max_events):
        lines += _md_section(s)
    return "\n".join(lines).rstrip() + "\n"


# ---------------------------------------------------------------------------------- HTML
_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em; color: #222; max-width: 75em; }
table { border-collapse: collapse; margin: 0.5em 0 1.2em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #eee; }
code { font-family: ui-monospace, monospace; background: #f4f4f4; padding: 0 0.2em; }
blockquote { border-left: 4px solid #c33; margin: 0.5em 0; padding: 0.3em 1em; }
.status { display: inline-block; padding: 0.2em 0.7em; border-radius: 0.3em; color: white; }
.status-success { background: #2a7d2a; } .status-anomaly { background: #c33; }
.status-budget-exhausted { background: #b60; }
tr.ev-failure td, tr.ev-anomaly td { background: #fde8e8; }
tr.ev-backtrack td { background: #fff4d6; }
tr.ev-success td { background: #eaf6ea; }
.note { font-style: italic; color: #555; }
"""


def _esc(text: str) -> str:
    return html.escape(text, quote=True)


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9-]", "-", text.lower())


def _html_table(t: _Table, timeline: bool = False) -> list[str]:
    def cell(v: str) -> str:
        return f"<td><code>{_esc(v)}</code></td>" if isinstance(v, _Code) else f"<td>{_esc(v)}</td>"

    out = ["<table>", "<tr>" + "".join(f"<th>{_esc(h)}</th>" for h in t.header) + "</tr>"]
    for r in t.rows:
        cls = f' class="ev-{_slug(r[3])}"' if timeline else ""
        out.append(f"<tr{cls}>" + "".join(map(cell, r)) + "</tr>")
    return [*out, "</table>"]


def _html_section(s: _Section) -> list[str]:
    out = [f"<h2>{_esc(s.title)}</h2>"]
    out += [f"<blockquote>{_esc(p)}</blockquote>" for p in s.prose]
    for t in s.tables:
        out += _html_table(t, timeline=s.title == "Timeline")
    if s.items_title:
        out.append(f"<h3>{_esc(s.items_title)}</h3>")
    if s.items:
        shown = (f"<code>{_esc(i)}</code>" if s.code else _esc(i) for i in s.items)
        out += ["<ul>", *(f"<li>{i}</li>" for i in shown), "</ul>"]
    if s.note:
        out.append(f'<p class="note">{_esc(s.note)}</p>')
    return out


def episode_html(episode: Episode, title: str = DEFAULT_TITLE, max_events: int = 500) -> str:
    """The episode as one self-contained HTML page (inline style, no scripts, no links)."""
    status = episode.status.value
    body = [
        f"<h1>{_esc(title)}</h1>",
        f'<p><span class="status status-{_slug(status)}">{_esc(status)}</span></p>',
    ]
    for s in _sections(episode, max_events):
        body += _html_section(s)
    head = (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{_esc(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
    )
    return head + "\n".join(body) + "\n</body>\n</html>\n"


# ---------------------------------------------------------------------------------- files
def _atomic_write(path: Path, text: str) -> Path:
    return atomic_write(path, printable(text))  # no control characters, no lone surrogates


def _save_json(episode: Episode, path: Path) -> Path:
    return episode.save(path)


def save_episode(
    episode: Episode,
    folder: str | Path,
    specs: Sequence[SubtreeSpec] | None = None,
    title: str = DEFAULT_TITLE,
) -> list[Path]:
    """Write ``episode.json``, ``report.md``, ``report.html`` and, given the plan's ``specs``,
    ``plan.xml`` plus one ``<ID>.xml`` per CSubBT (BehaviorTree.CPP v4) into ``folder``.

    Returns the paths written, in that order.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = [
        _save_json(episode, folder / "episode.json"),
        _atomic_write(folder / "report.md", episode_markdown(episode, title)),
        _atomic_write(folder / "report.html", episode_html(episode, title)),
    ]
    for name, xml in (to_btcpp_files(specs) if specs else {}).items():
        written.append(_atomic_write(folder / name, xml))
    log.info("saved episode (%s) to %s: %d files", episode.status.value, folder, len(written))
    return written


__all__ = ["DEFAULT_TITLE", "episode_html", "episode_markdown", "save_episode"]
