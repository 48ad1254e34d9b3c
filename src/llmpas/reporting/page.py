"""``index.html``: one page per run folder — the whole closed loop at a glance.

The outcome, task, world, LLM, method and timings at the top with the animated episode; a strip
of the rounds; then one section per round: the plan, the CSubBT diagrams (Graphviz, from the
XML on disk), the anomaly report, the timeline with the snapshots and camera images at the
events that made them, and the reasoning (every prompt and answer, the goals taken, what the
validator dropped, reinterpreted or sent back, the repairs); links to the raw files last.

The page is self-contained: no script, no network; images are inlined as data URIs up to a byte
budget, beyond which they are linked relative to the page. Every text from a file or an LLM is
escaped by :func:`llmpas.reporting.html.text`.
"""

from __future__ import annotations

import base64
import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from llmpas.files import atomic_write
from llmpas.reasoning.truth_oracle import ORACLE
from llmpas.reporting import diagram
from llmpas.reporting.html import Markup, href, join, slug, tag, void
from llmpas.reporting.run_folder import (
    DEFERS,
    Exchange,
    Media,
    Reasoning,
    Round,
    RunRecord,
    get_float,
    get_list,
    get_map,
    get_str,
    read_run,
    strings,
)

log = logging.getLogger(__name__)

INLINE_BUDGET = 3_000_000  # bytes of images inlined per page; later ones are linked
MAX_EVENTS = 400  # timeline rows per round
MAX_IMAGES = 500  # snapshots and camera images shown per page
MAX_TEXT = 20_000  # characters of one prompt or answer shown
_MIME = {".png": "image/png", ".gif": "image/gif", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}
_MIME[".webp"] = "image/webp"

CSS = """
:root { --ink:#1f2430; --muted:#5d6575; --line:#dde1e8; --bg:#f6f7f9; --ok:#1f8a4c;
  --bad:#c0392b; --warn:#b7791f; --accent:#3b6fb6; }
* { box-sizing: border-box; }
body { margin:0; font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;
  color:var(--ink); background:var(--bg); }
main { max-width:1180px; margin:0 auto; padding:24px 28px 60px; }
h1 { font-size:28px; margin:0 0 6px; } h2 { font-size:21px; margin:0 0 12px; }
h3 { font-size:16px; margin:18px 0 8px; color:var(--muted); text-transform:uppercase;
  letter-spacing:.04em; }
code, pre, .mono { font-family:ui-monospace,"SFMono-Regular",Menlo,Consolas,monospace;
  font-size:13px; }
pre { white-space:pre-wrap; word-break:break-word; background:#f3f4f7; border:1px solid var(--line);
  border-radius:6px; padding:10px 12px; margin:6px 0; max-height:480px; overflow:auto; }
.card { background:white; border:1px solid var(--line); border-radius:10px; padding:18px 20px;
  margin:0 0 20px; box-shadow:0 1px 2px rgba(0,0,0,.04); }
.hero { display:grid; grid-template-columns: minmax(0,1fr) 400px; gap:24px; align-items:start; }
.hero img.gif { width:100%; border-radius:8px; border:1px solid var(--line); }
.badge { display:inline-block; padding:3px 10px; border-radius:999px; color:white;
  font-weight:600; font-size:13px; vertical-align:middle; }
.b-success,.b-done { background:var(--ok); }
.b-anomaly,.b-failure,.b-not-done { background:var(--bad); }
.b-no-plan,.b-other,.b-unknown,.b-budget-exhausted { background:var(--warn); }
.message { color:var(--muted); margin:4px 0 14px; }
dl.facts { display:grid; grid-template-columns:max-content 1fr; gap:4px 16px; margin:0; }
dl.facts dt { color:var(--muted); } dl.facts dd { margin:0; }
.bar { display:flex; height:14px; border-radius:7px; overflow:hidden; background:#eceef2;
  margin:6px 0 4px; }
.bar span { display:block; height:100%; }
.t-plan { background:#3b6fb6; } .t-execute { background:#1f8a4c; } .t-llm { background:#8e44ad; }
.legend span { margin-right:14px; color:var(--muted); font-size:13px; }
.legend i { display:inline-block; width:10px; height:10px; border-radius:2px; margin-right:4px; }
.story { display:flex; flex-wrap:wrap; gap:8px; align-items:stretch; }
.story a { text-decoration:none; color:inherit; }
.step { border:1px solid var(--line); border-left:5px solid var(--warn); border-radius:8px;
  padding:8px 12px; background:white; min-width:170px; max-width:260px; }
.step.s-success { border-left-color:var(--ok); } .step.s-anomaly { border-left-color:var(--bad); }
.step.llm { border-left-color:#8e44ad; background:#faf6fc; }
.arrow { align-self:center; color:var(--muted); font-size:20px; }
.small { font-size:12.5px; color:var(--muted); }
.split { display:grid; grid-template-columns:minmax(0,1fr) minmax(0,1.5fr); gap:20px; }
.split > div:only-child { grid-column:1 / -1; }
ol.plan { margin:0; padding-left:24px; } ol.plan li { margin:2px 0; }
.trees { display:flex; gap:12px; overflow-x:auto; }
.trees figure { margin:0; flex:0 0 auto; max-width:100%; border:1px solid var(--line);
  border-radius:8px; padding:8px; background:#fcfcfd; overflow:auto; }
.trees img { max-height:340px; max-width:100%; width:auto; display:block; margin:auto; }
figcaption { font-size:12.5px; color:var(--muted); margin-bottom:6px; }
.anomaly { border:1px solid #f1b0a8; border-left:6px solid var(--bad); background:#fff5f4;
  border-radius:8px; padding:12px 16px; margin:12px 0; }
.anomaly .headline { font-size:16px; font-weight:600; color:#8e1f14; }
table { border-collapse:collapse; width:100%; margin:6px 0; }
th, td { border-bottom:1px solid var(--line); padding:4px 8px; text-align:left;
  vertical-align:top; }
th { background:#f3f4f7; font-weight:600; font-size:13px; }
td.num { text-align:right; white-space:nowrap; font-variant-numeric:tabular-nums; }
tr.e-failure td { background:#fdeeee; } tr.e-backtrack td { background:#fff7e3; }
tr.e-anomaly td { background:#f9d6d2; font-weight:600; } tr.e-success td.st { color:var(--ok); }
td.shots { width:280px; padding:2px 4px; }
.shots figure { display:inline-block; margin:2px 4px 2px 0; vertical-align:top; width:132px; }
.shots figcaption { font-size:11px; line-height:1.2; margin:1px 0 0; }
.gallery figure { width:200px; }
.shots img { width:100%; height:auto; border-radius:6px; border:1px solid var(--line); }
.chips span { display:inline-block; background:#eef3fb; border:1px solid #c9d8ef; border-radius:6px;
  padding:1px 8px; margin:2px 4px 2px 0; }
.chips.bad span { background:#fdeeee; border-color:#f1b0a8; }
ul.validator { margin:4px 0; padding-left:20px; }
ul.validator li.sent { color:#8e1f14; } ul.validator li.note { color:#7a5200; }
details { border:1px solid var(--line); border-radius:8px; padding:6px 12px; margin:6px 0;
  background:#fcfcfd; }
details > summary { cursor:pointer; font-weight:600; }
.role { font-size:12px; color:var(--muted); text-transform:uppercase; margin-top:6px; }
.answer pre { background:#f7f2fb; border-color:#dcc8ea; }
ul.files { columns:2; font-size:13.5px; }
.note { color:var(--muted); font-style:italic; } .nw { white-space:nowrap; }
@media (max-width:900px) { .hero { grid-template-columns:1fr; } }
"""


@dataclass
class Images:
    """Image sources: data URIs until ``budget`` bytes are used, then relative links."""

    folder: Path
    budget: int = INLINE_BUDGET
    used: int = 0
    cache: dict[str, str] = field(default_factory=dict)
    drawn: dict[str, str] = field(default_factory=dict)  # a diagram's source -> its figure id
    figures: int = 0  # images placed (beyond MAX_IMAGES they are only in the folder)

    def inline(self, data: bytes, mime: str) -> str | None:
        """``data`` as a data URI, or None when the budget is spent."""
        if self.used + len(data) > self.budget:
            return None
        self.used += len(data)
        return f"data:{mime};base64,{base64.b64encode(data).decode()}"

    def src(self, rel: str) -> str:
        if rel in self.cache:
            return self.cache[rel]
        path = self.folder / rel
        mime = _MIME.get(path.suffix.lower())
        out = href(rel)
        try:
            if mime and self.used + path.stat().st_size <= self.budget:
                out = self.inline(path.read_bytes(), mime) or out
        except OSError as e:
            log.warning("%s: %s", path, e)
        self.cache[rel] = out
        return out


def _status_badge(status: str) -> Markup:
    known = {"success", "anomaly", "failure", "no-plan", "done", "not-done", "budget-exhausted"}
    s = slug(status)
    return tag("span", status, class_=f"badge b-{s if s in known else 'other'}")


def _seconds(x: float | None) -> str:
    return "—" if x is None else f"{x:.2f} s"


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _clip(value: str) -> str:
    if len(value) <= MAX_TEXT:
        return value
    return value[:MAX_TEXT] + f"\n… ({len(value) - MAX_TEXT} more characters in the raw files)"


# ------------------------------------------------------------------------------------ top


def _timings(run: RunRecord) -> dict[str, float | None]:
    """plan / execute / LLM seconds: as recorded, else summed over the rounds."""
    plans = [r.plan_time for r in run.rounds if r.plan_time is not None]
    runs = [r.duration for r in run.rounds if r.duration is not None]
    llm = [
        e.latency
        for r in run.rounds
        if r.reasoning
        for e in r.reasoning.exchanges
        if e.latency is not None
    ]
    return {
        "plan": run.timings.get("plan", sum(plans) if plans else None),
        "execute": run.timings.get("execute", sum(runs) if runs else None),
        "LLM": run.llm_time if run.llm_time is not None else (sum(llm) if llm else None),
        "total": run.timings.get("total"),
    }


def _timing_bar(t: Mapping[str, float | None]) -> Markup:
    parts = {k: v for k, v in t.items() if k != "total" and v}
    whole = sum(v for v in parts.values() if v) or 1.0
    spans = [
        tag("span", class_=f"t-{slug(k)}", style=f"width:{100 * v / whole:.1f}%", title=k)
        for k, v in parts.items()
        if v
    ]
    legend = [
        tag("span", tag("i", class_=f"t-{slug(k)}"), f"{k} {_seconds(v)}")
        for k, v in t.items()
        if k != "total"
    ]
    total = t.get("total")
    if total is not None:
        legend.append(tag("span", f"wall clock {_seconds(total)}"))
    return join([tag("div", *spans, class_="bar"), tag("div", *legend, class_="legend")])


def _llm_line(run: RunRecord) -> str:
    models = sorted(
        {e.model for r in run.rounds if r.reasoning for e in r.reasoning.exchanges if e.model}
    )
    spec = get_str(run.about, "llm")
    shown = spec or ", ".join(models)
    if shown == ORACLE:
        return "oracle (reads the simulator's true state: an upper bound, not an LLM)"
    if models and spec and models != [spec]:
        shown += f" (model: {', '.join(models)})"
    return shown or ("none (no LLM in this run)" if not run.loop else "—")


def _method_line(run: RunRecord) -> str:
    methods = sorted({r.reasoning.method for r in run.rounds if r.reasoning and r.reasoning.method})
    method = get_str(run.about, "method") or ", ".join(methods)
    decoding = get_str(run.about, "decoding")
    if not run.loop:
        return "execution only (no reasoning)"
    return f"{method or '—'}" + (f", {decoding} decoding" if decoding else "")


def _hero(run: RunRecord, images: Images) -> Markup:
    outcome = "unknown" if run.success is None else "done" if run.success else "not done"
    title = "task done" if run.success else "task not done" if run.success is False else "outcome"
    if run.basis == "perceived" and run.success is not None:
        title += " (perceived)"
    calls = sum(len(r.reasoning.exchanges) for r in run.rounds if r.reasoning)
    facts = [
        ("task", tag("code", run.task or "—")),
        *(
            [("verdict", "what the robot perceived (its detections and gripper), no ground truth")]
            if run.basis == "perceived"
            else []
        ),
        ("world", get_str(run.about, "world") or "—"),
        ("LLM", _llm_line(run)),
        ("method", _method_line(run)),
        ("rounds", f"{len(run.rounds)} plan-and-execute rounds, {calls} LLM calls"),
    ]
    dl = tag("dl", *(Markup(tag("dt", k) + tag("dd", v)) for k, v in facts), class_="facts")
    left = [
        tag("h1", run.scenario, " ", tag("span", title, class_=f"badge b-{slug(outcome)}")),
        tag("p", run.message or " ", class_="message"),
        *_scenario_line(run),
        dl,
        tag("h3", "time"),
        _timing_bar(_timings(run)),
    ]
    cmd = get_str(run.about, "command")
    if cmd:
        words = join([tag("span", w, class_="nw") for w in cmd.split()], " ")
        left.append(tag("p", "made by ", tag("code", words), class_="small"))
    right: list[Markup] = []
    if run.gif:
        right = [
            tag(
                "a",
                void("img", src=images.src(run.gif), alt="the episode, animated", class_="gif"),
                href=href(run.gif),
            ),
            tag("div", "the episode (snapshots at key moments, animated)", class_="small"),
        ]
    return tag(
        "section",
        tag("div", *left),
        tag("div", *right),
        class_="card hero",
        id="outcome",
    )


def _scenario_line(run: RunRecord) -> list[Markup]:
    """What happens in the scenario (its description: where a moved object went), if known."""
    text = get_str(run.about, "description")
    return [tag("p", tag("b", "scenario: "), text, class_="small")] if text else []


def _story(run: RunRecord) -> Markup:
    items: list[Markup] = []
    for r in run.rounds:
        if items:
            items.append(tag("span", "→", class_="arrow"))
        anomaly = r.anomaly
        what = f"{get_str(anomaly, 'constraint')} failed" if anomaly else f"{len(r.plan)} actions"
        items.append(
            tag(
                "a",
                tag(
                    "div",
                    tag("div", tag("b", f"Round {r.index}"), " ", _status_badge(r.status)),
                    tag("div", tag("code", r.goal), class_="small"),
                    tag("div", what, class_="small"),
                    class_=f"step s-{slug(r.status)}",
                ),
                href=f"#round-{r.index}",
            )
        )
        if r.reasoning is not None:
            goals = " ".join(r.reasoning.goals) or f"no goals ({r.reasoning.status})"
            items += [
                tag("span", "→", class_="arrow"),
                tag(
                    "a",
                    tag(
                        "div",
                        tag("div", tag("b", f"LLM ({r.reasoning.method})")),
                        tag("div", tag("code", goals), class_="small"),
                        tag("div", _count(r.reasoning.repairs or 0, "repair"), class_="small"),
                        class_="step llm",
                    ),
                    href=f"#reasoning-{r.index}",
                ),
            ]
    story = tag("div", *items, class_="story")
    return tag("section", tag("h2", "The loop"), story, class_="card", id="loop")


def _difference(run: RunRecord) -> Markup:
    """Which of the LLM's goals made the difference, and the replan-only run of the same
    scenario and seed (when the folder has one)."""
    from llmpas.reporting.difference import difference

    d = difference(run)
    if not d.outcomes and d.baseline is None:
        return Markup("")
    rows = [
        tag(
            "tr",
            tag("td", tag("a", f"round {o.round}", href=f"#reasoning-{o.round}")),
            tag("td", tag("code", " ".join(o.goals) or "none")),
            tag("td", tag("b", o.fate) if o.goals == d.decisive and d.decisive else o.fate),
        )
        for o in d.outcomes
    ]
    parts = [tag("h2", "What the LLM's goals did"), tag("p", d.verdict)]
    if rows:
        head = tag("tr", tag("th", "answer to"), tag("th", "goals"), tag("th", "outcome"))
        parts.append(tag("table", head, *rows))
    if d.baseline is not None:
        verdict = {True: "task done", False: "not done", None: "no verdict"}[d.baseline.success]
        link = tag("a", "the replan-only run", href=href(f"{d.baseline.folder}/index.html"))
        parts.append(
            tag(
                "p",
                "Same scenario and seed without the LLM: ",
                link,
                f" — {verdict}, ",
                f"{d.baseline.rounds} rounds: {d.baseline.message}",
            )
        )
    return tag("section", *parts, class_="card", id="difference")


# --------------------------------------------------------------------------------- rounds


def _plan(r: Round) -> Markup:
    if not r.plan and r.episode is not None:
        return tag("p", "The plan's steps are not recorded here: see its subtrees.", class_="note")
    if not r.plan:
        return tag("p", "No plan was found.", class_="note")
    when = f" (planned in {r.plan_time:.2f} s)" if r.plan_time is not None else ""
    items = []
    for step in r.plan:
        action, _, deferred = step.partition(DEFERS)
        later = tag("div", "defers ", deferred, class_="small") if deferred else ""
        items.append(tag("li", tag("code", action), later))
    return join([tag("h3", f"plan{when}"), tag("ol", *items, class_="plan")])


def _drawing(tree: diagram.Tree, images: Images) -> Markup:
    """The tree as an SVG image (Graphviz), or as text without Graphviz or budget."""
    svg = diagram.to_svg(tree) if images.used < images.budget else None
    uri = images.inline(svg, "image/svg+xml") if svg is not None else None
    if uri is None:
        return tag("pre", diagram.to_text(tree))
    return void("img", src=uri, alt=f"CSubBT {tree.ident}")


def _trees(run: RunRecord, r: Round, images: Images) -> Markup:
    """The round's CSubBTs; one drawn in an earlier round is linked, not drawn again."""
    plan = [x for x in r.xml if Path(x).name == "plan.xml"]  # every subtree, in plan order
    files = plan or list(r.xml)
    figures: list[Markup] = []
    for rel in files:
        for tree in diagram.read_trees(run.folder / rel):
            anchor = f"tree-{r.index}-{len(figures)}"
            own = str(Path(rel).with_name(f"{tree.ident}.xml").as_posix())
            xml = own if own in r.xml else rel
            caption = tag("figcaption", tree.ident, " · ", tag("a", "XML", href=href(xml)))
            source = diagram.to_dot(tree)
            if source in images.drawn:
                link = tag("a", "drawn above", href=f"#{images.drawn[source]}")
                body = tag("p", "the same subtree as ", link, class_="note")
            else:
                images.drawn[source] = anchor
                body = _drawing(tree, images)
            figures.append(tag("figure", caption, body, id=anchor))
    if not figures:
        return tag("p", "No subtree XML in this folder.", class_="note")
    return join([tag("h3", "conditional behaviour subtrees"), tag("div", *figures, class_="trees")])


def _anomaly(a: Mapping[str, Any]) -> Markup:
    constraint = get_str(a, "constraint")
    headline = f"{constraint} does not hold: {get_str(a, 'reason')}"
    args = ", ".join(strings(get_list(a, "args")))
    rows = [
        ("action", f"{get_str(a, 'action')}({args})"),
        ("sub-action", get_str(a, "sub_action")),
        ("constraint", f"{get_str(a, 'constraint_name')} {constraint}"),
        ("alternatives explored", get_str(a, "attempts")),
    ]
    rows += [
        (f"tried {dim}", ", ".join(strings(vals)) if isinstance(vals, list) else str(vals))
        for dim, vals in get_map(a, "explored").items()
    ]
    table = tag(
        "table",
        *(tag("tr", tag("th", k), tag("td", tag("code", v))) for k, v in rows),
    )
    obs = strings(get_list(a, "observations"))
    parts = [tag("div", "Anomaly: ", tag("code", headline), class_="headline"), table]
    if obs:
        parts.append(tag("div", "observations", class_="small"))
        parts.append(tag("ul", *(tag("li", o) for o in obs)))
    return tag("div", *parts, class_="anomaly")


def _figure(m: Media, images: Images) -> Markup:
    images.figures += 1
    if images.figures > MAX_IMAGES:
        return Markup("")
    img = void("img", src=images.src(m.path), alt=m.label or m.path)
    caption = tag("figcaption", f"{m.kind}: {m.label}")
    return tag("figure", tag("a", img, href=href(m.path)), caption)


def _changed(e: Any, before: Mapping[str, Any]) -> str:
    """The event's values that differ from the previous event's."""
    values = get_map(e, "values")
    return "  ".join(f"{k}={v}" for k, v in values.items() if before.get(k) != v)


def _event_row(i: int | None, e: Any, before: Mapping[str, Any], shots: Markup) -> Markup:
    t = get_float(e, "t")
    status = get_str(e, "status")
    return tag(
        "tr",
        tag("td", "" if i is None else str(i), class_="num"),
        tag("td", "" if t is None else f"{t:.2f}", class_="num"),
        tag("td", tag("code", get_str(e, "node"))),
        tag("td", status, class_="st"),
        tag("td", get_str(e, "message"), tag("div", _changed(e, before), class_="small mono")),
        tag("td", shots, class_="shots"),
        class_=f"e-{slug(status)}",
    )


def _timeline(r: Round, media: Sequence[Media], images: Images) -> Markup:
    """One row per event, with the images made while it ran beside it; a value is shown where
    it changed."""
    events = r.timeline
    if not events:
        return tag("p", "No timeline recorded.", class_="note")
    shown = events[:MAX_EVENTS]
    at: dict[int, list[Markup]] = {}
    for m in media:
        at.setdefault(min(m.event or 0, len(shown)), []).append(_figure(m, images))
    head = ("#", "t (s)", "node", "status", "message and changed values", "seen")
    rows = [tag("tr", *(tag("th", h) for h in head))]
    before: Mapping[str, Any] = {}
    for i, e in enumerate(shown):
        rows.append(_event_row(i, e, before, join(at.get(i, ()))))
        before = get_map(e, "values")
    if len(shown) in at:
        end = {"node": "(after the last event)"}
        rows.append(_event_row(None, end, {}, join(at[len(shown)])))
    left = len(events) - len(shown)
    note = tag("p", f"{left} later events are in episode.json.", class_="note") if left else ""
    return join([tag("h3", f"timeline ({len(events)} events)"), tag("table", *rows), note])


def _message(role: str, content: str) -> Markup:
    return join([tag("div", role, class_="role"), tag("pre", _clip(content))])


def _exchange(e: Exchange, open_: bool) -> Markup:
    prompt = [_message(role, content) for role, content in e.messages]
    meta = [e.model or "?", f"{e.tokens} tokens" if e.tokens else "", _seconds(e.latency)]
    summary = tag(
        "summary",
        f"{e.tag or 'exchange'} ",
        tag("span", " · ".join(filter(None, meta)), class_="small"),
    )
    answer = tag("div", _message("answer", e.response), class_="answer")
    return tag("details", summary, *prompt, answer, open=open_)


def _reasoning(r: Round, x: Reasoning) -> Markup:
    goals = (
        tag("div", *(tag("span", g) for g in x.goals), class_="chips")
        if x.goals
        else tag(
            "div", tag("span", f"no goals taken ({x.status or 'rejected'})"), class_="chips bad"
        )
    )
    validator: list[Markup] = []
    for e in x.exchanges:
        if e.tag.startswith("repair") and e.messages:
            sent = e.messages[-1][1]
            reasons = [x[2:] for x in sent.splitlines() if x.startswith("- ")] or [sent]
            for why in reasons:
                validator.append(
                    tag("li", f"sent back ({e.tag}): ", tag("code", why), class_="sent")
                )
    validator += [tag("li", f"rejected: {err}", class_="sent") for err in x.errors]
    validator += [tag("li", note, class_="note") for note in x.notes]
    if not validator:
        validator = [tag("li", "took the answer as given")]
    parts = [
        tag("h3", f"reasoning ({x.method})", id=f"reasoning-{r.index}"),
        tag("div", "goals taken: ", goals),
        tag("div", f"validator ({_count(x.repairs or 0, 'repair')}):", class_="small"),
        tag("ul", *validator, class_="validator"),
    ]
    if x.first_look:
        parts.append(tag("div", "first look: ", tag("code", x.first_look), class_="small"))
    if x.candidates:
        parts.append(_candidates(x.candidates))
    parts += [_exchange(e, open_=False) for e in x.exchanges]
    return join(parts)


def _candidates(cands: Sequence[tuple[str, float | None, bool]]) -> Markup:
    """The candidate goal sets of a choosing method, ranked, with their scores (the model's
    mean token log-probability; none for a control) and the one chosen."""
    rows = [
        tag(
            "tr",
            tag("td", str(i)),
            tag("td", tag("code", goals)),
            tag("td", "—" if score is None else f"{score:.3f}"),
            tag("td", "chosen" if chosen else ""),
            class_="chosen" if chosen else None,
        )
        for i, (goals, score, chosen) in enumerate(cands, 1)
    ]
    head = tag(
        "tr", tag("th", "#"), tag("th", "candidate goals"), tag("th", "score"), tag("th", "")
    )
    return tag(
        "details",
        tag("summary", f"{len(cands)} candidate goal sets, ranked"),
        tag("table", head, *rows, class_="candidates"),
        open=True,
    )


def _round(run: RunRecord, r: Round, images: Images) -> Markup:
    media = run.media_of(r)
    top = [tag("div", _plan(r))]
    if r.anomaly:
        top.append(tag("div", _anomaly(r.anomaly)))
    parts = [
        tag("h2", f"Round {r.index} ", _status_badge(r.status)),
        tag("div", "goal ", tag("code", r.goal or "—"), class_="small"),
        *([tag("p", r.note, class_="note")] if r.note else []),
        tag("div", *top, class_="split"),
        _trees(run, r, images),
    ]
    if r.episode is not None:
        parts.append(_timeline(r, media, images))
    if r.reasoning is not None:
        parts.append(_reasoning(r, r.reasoning))
    parts += [tag("p", problem, class_="note") for problem in r.problems]
    return tag("section", *parts, class_="card round", id=f"round-{r.index}")


# ---------------------------------------------------------------------------------- page


def _gallery(run: RunRecord, images: Images) -> Markup:
    """Images no event claims (no media.json, or made outside every episode)."""
    placed = {m.path for r in run.rounds if r.timeline for m in run.media_of(r)}
    rest = [m for m in run.media if m.path not in placed]
    if not rest:
        return Markup("")
    figures = [_figure(m, images) for m in rest]
    return tag(
        "section",
        tag("h2", "Snapshots and camera images"),
        tag("div", *figures, class_="shots gallery"),
        class_="card",
        id="images",
    )


def _files(run: RunRecord, images: Images) -> Markup:
    items = [tag("li", tag("a", rel, href=href(rel))) for rel in run.raw]
    log_lines = [tag("li", line) for line in run.world_log]
    parts = [tag("h2", "Raw files"), tag("ul", *items, class_="files")]
    if run.artifacts:
        recorded = [
            tag("li", tag("a", a.file, href=href(a.file)), f" ({a.title}): {a.holds}")
            for a in run.artifacts
        ]
        parts += [tag("h3", "recordings"), tag("ul", *recorded, class_="files")]
    if images.figures > MAX_IMAGES:
        left = images.figures - MAX_IMAGES
        parts.append(tag("p", f"{left} more images are only in the folder.", class_="note"))
    if log_lines:
        parts += [tag("h3", "world log"), tag("ol", *log_lines, class_="small")]
    return tag("section", *parts, class_="card", id="files")


def render(run: RunRecord, budget: int = INLINE_BUDGET) -> str:
    """The page of ``run`` as HTML text."""
    images = Images(run.folder, budget)
    body = [
        _hero(run, images),
        _story(run) if run.loop else Markup(""),
        _difference(run) if run.loop else Markup(""),
        *(_round(run, r, images) for r in run.rounds),
        _gallery(run, images),
        _files(run, images),
    ]
    title = f"{run.scenario}: {'task done' if run.success else 'run report'}"
    head = join(
        [
            void("meta", charset="utf-8"),
            void("meta", name="viewport", content="width=device-width, initial-scale=1"),
            void("meta", http_equiv="Content-Security-Policy", content=_CSP),
            tag("title", title),
            tag("style", Markup(CSS)),
        ]
    )
    html = tag("html", tag("head", head), tag("body", tag("main", *body)), lang="en")
    return "<!DOCTYPE html>\n" + html + "\n"


# no script at all, images only from the page itself (data URIs or files beside it)
_CSP = "default-src 'none'; img-src data: 'self' file:; style-src 'unsafe-inline'; base-uri 'none'"


@dataclass(frozen=True)
class Built:
    path: Path
    bytes: int
    seconds: float


def build_report(folder: str | Path, about: Mapping[str, Any] | None = None) -> Built:
    """Write ``index.html`` into a run folder from what is on disk (``about``: what the command
    knew — world, LLM, method — saved as ``about.json`` first so that a rebuild shows it)."""
    import json

    t0 = time.perf_counter()
    folder = Path(folder)
    if about:
        atomic_write(folder / "about.json", json.dumps(dict(about), indent=2))
    page = render(read_run(folder))
    path = atomic_write(folder / "index.html", page)
    return Built(path, len(page.encode()), time.perf_counter() - t0)


__all__ = ["CSS", "Built", "Images", "build_report", "render"]
