"""``index.html`` of ``llmpas bench prompting``: Table II as a web page, each cell linking to the
samples behind it, and each sample to its run's own page when the runs were kept
(``--keep-runs``). Self-contained like the run pages (:mod:`llmpas.reporting`)."""

from __future__ import annotations

import base64
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from llmpas.experiments.prompting import Cell, PromptingConfig, method_label, run_folder
from llmpas.experiments.prompting_tables import categories
from llmpas.files import atomic_write
from llmpas.reporting.html import Markup, href, join, slug, tag, void
from llmpas.reporting.page import CSS

_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; base-uri 'none'"
_EXTRA_CSS = """
td a.cell { display:block; text-decoration:none; color:inherit; font-variant-numeric:tabular-nums; }
td a.cell:hover { background:#eef3fb; }
tr.v-success td.v { color:var(--ok); }
tr.v-not-done td.v, tr.v-false-done td.v { color:var(--bad); }
img.plot { max-width:100%; }
"""


def _anchor(method: str, category: str) -> str:
    return f"m-{slug(method)}-{slug(category)}"


def _f(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f}"


def _table(cells: Sequence[Cell], config: PromptingConfig) -> Markup:
    methods = list(dict.fromkeys(c.method for c in cells))
    cats = [c for c, _ in categories(x.category for x in cells)] + ["all"]
    get = {(c.method, c.category): c for c in cells}
    head = [tag("th", "method")]
    head += [tag("th", f"{c} SR", " / ", "ASPL", " / ", "1st eff.") for c in cats]
    head.append(tag("th", "lift over replan (all)"))
    rows = [tag("tr", *head)]
    for m in methods:
        tds = [tag("td", method_label(m, config.llm))]
        for cat in cats:
            cell = get.get((m, cat))
            shown = f"{_f(cell.sr)} / {_f(cell.aspl)} / {_f(cell.first_effective)}" if cell else "—"
            link = tag("a", shown, href=f"#{_anchor(m, cat)}", class_="cell") if cell else shown
            tds.append(tag("td", link, class_="num"))
        every = get.get((m, "all"))
        lift = every.lift if every is not None else None
        tds.append(tag("td", "—" if lift is None else f"{lift:+.2f}", class_="num"))
        rows.append(tag("tr", *tds))
    return tag("table", *rows)


def _samples(records: Sequence[Mapping[str, Any]], config: PromptingConfig) -> Markup:
    """One table per method and anomaly type: the samples, linked to their kept runs."""
    out: list[Markup] = []
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in records:
        groups.setdefault((str(r.get("method")), str(r.get("category"))), []).append(r)
    head: tuple[str, ...] = ("task", "sample", "verdict", "first goals", "1st eff.", "goals")
    head += ("repairs", "LLM s", "run")
    seen: set[str] = set()
    for (method, cat), rs in groups.items():
        if method not in seen:  # the method's "all" cell links to its first group
            seen.add(method)
            out.append(tag("span", id=_anchor(method, "all")))
        rows = [tag("tr", *(tag("th", h) for h in head))]
        for r in sorted(rs, key=lambda r: (str(r.get("task")), str(r.get("sample")))):
            rows.append(_sample_row(r, config))
        title = f"{method_label(method, config.llm)}: {cat}"
        out.append(tag("h3", title, id=_anchor(method, cat)))
        out.append(tag("table", *rows))
    return join(out)


def _sample_row(r: Mapping[str, Any], config: PromptingConfig) -> Markup:
    key = str(r.get("key", ""))
    folder = run_folder(config, key) if key else None
    page = folder / "index.html" if folder else None
    if page is not None and page.is_file():
        rel = page.relative_to(config.out_dir).as_posix()
        run: Markup | str = tag("a", "open", href=href(rel))
    else:
        run = "not kept"
    goals = r.get("goals")
    verdict = str(r.get("verdict", ""))
    cells = [
        r.get("task", ""),
        r.get("sample", ""),
        tag("span", verdict),
        str(r.get("first_goals", "")),
        _yes_no(r.get("first_effective")),
        " ".join(map(str, goals)) if isinstance(goals, list) else str(goals or ""),
        r.get("repairs", ""),
        r.get("latency", ""),
        run,
    ]
    tds = [tag("td", c, class_="v" if i == 2 else None) for i, c in enumerate(cells)]
    return tag("tr", *tds, class_=f"v-{slug(verdict)}")


def _yes_no(value: object) -> str:
    return "—" if value is None else "yes" if value else "no"


def render_page(
    records: Sequence[Mapping[str, Any]], cells: Sequence[Cell], config: PromptingConfig
) -> str:
    plot = config.out_dir / "prompting.png"
    parts = [
        tag("h1", f"Prompting methods on {config.subject}"),
        tag(
            "p",
            f"LLM: {config.llm}; {config.samples} sample(s) per task and method at temperature "
            f"{config.temperature:g} (the oracle and replan: 1); at most {config.max_rounds} LLM "
            "rounds per run. SR: success rate; ASPL = (1/n) Σ (L̄_i / L_gt,i) × SR_i; 1st eff.: "
            "share of first proposals that entail an effective goal set; lift: SR minus the "
            "replan row's (the task goal restated, no reasoning). A cell links to its "
            "samples" + (", each to its run." if config.keep_runs else "."),
            class_="message",
        ),
        _table(cells, config),
    ]
    if plot.is_file():
        uri = "data:image/png;base64," + base64.b64encode(plot.read_bytes()).decode()
        parts.append(void("img", src=uri, alt="SR and ASPL per method", class_="plot"))
    body = [tag("section", *parts, class_="card", id="table")]
    body.append(tag("section", tag("h2", "Samples"), _samples(records, config), class_="card"))
    head = join(
        [
            void("meta", charset="utf-8"),
            void("meta", http_equiv="Content-Security-Policy", content=_CSP),
            tag("title", "Prompting methods (Table II)"),
            tag("style", Markup(CSS + _EXTRA_CSS)),
        ]
    )
    page = tag("html", tag("head", head), tag("body", tag("main", *body)), lang="en")
    return "<!DOCTYPE html>\n" + page + "\n"


def write_page(
    records: Sequence[Mapping[str, Any]], cells: Sequence[Cell], config: PromptingConfig
) -> Path:
    return atomic_write(config.out_dir / "index.html", render_page(records, cells, config))


__all__ = ["render_page", "write_page"]
