r"""The prompting experiment's tables: the per-sample records summarised into :class:`Cell`\ s
(SR with its Wilson interval, ASPL, first-proposal effective rate, lift over replan), written as
``prompting.md`` (Table II and the extra metrics), ``prompting.csv``, ``prompting.json``,
``prompting_samples.csv`` and ``prompting.png``. The experiment itself:
:mod:`llmpas.experiments.prompting`."""

from __future__ import annotations

import json
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from llmpas.experiments.prompting_config import (
    BASELINE,
    ORACLE,
    UPPER_BOUND,
    PromptingConfig,
    row_id,
    variants,
)
from llmpas.experiments.suite import (
    Category,
)
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.reasoning.methods import (
    REGISTRY,
    controls,
)
from llmpas.reasoning.replan import REPLAN

# ---------------------------------------------------------------------------------- summary


@dataclass(frozen=True)
class Cell:
    """One method on one anomaly type (or ``all``)."""

    method: str
    category: str
    tasks: int
    samples: int
    sr: float
    aspl: float | None  # None: a task has no ground-truth resolution length (a world's scenario)
    syntax_error_rate: float | None  # None: no goal answers were read (e.g. none asked)
    repairs: float  # per sample
    tokens: float  # per sample
    latency: float  # seconds per sample
    completion: float  # share of samples the loop reported done
    false_done: int  # samples the loop believed done but the truth disagreed
    first_effective: float | None = None  # share of first proposals that are effective
    lift: float | None = None  # SR minus the replan row's SR (None: no replan row, a baseline)
    sr_low: float = 0.0  # 95 % Wilson interval of the pooled samples' success rate
    sr_high: float = 1.0


def _cell(method: str, category: str, records: Sequence[dict[str, Any]]) -> Cell:
    by_task: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        by_task.setdefault(str(r["task"]), []).append(r)
    srs = [sum(bool(r["success"]) for r in rs) / len(rs) for rs in by_task.values()]
    n = len(by_task)
    answers = sum(int(r["answers"]) for r in records)
    count = len(records)
    judged = [bool(r["first_effective"]) for r in records if r.get("first_effective") is not None]
    low, high = wilson(sum(bool(r["success"]) for r in records), count)
    return Cell(
        method=method,
        category=category,
        tasks=n,
        samples=count,
        sr=sum(srs) / n,
        aspl=_aspl(by_task.values()),
        syntax_error_rate=(
            sum(int(r["syntax_errors"]) for r in records) / answers if answers else None
        ),
        repairs=sum(int(r["repairs"]) for r in records) / count,
        tokens=sum(int(r["tokens"]) for r in records) / count,
        latency=sum(float(r["latency"]) for r in records) / count,
        completion=sum(bool(r["completed"]) for r in records) / count,
        false_done=sum(r["verdict"] == "false-done" for r in records),
        first_effective=sum(judged) / len(judged) if judged else None,
        sr_low=low,
        sr_high=high,
    )


def _aspl(tasks: Iterable[Sequence[Mapping[str, Any]]]) -> float | None:
    """(1/n) Σ (L̄_i / L_gt,i) × SR_i over the tasks' samples (None: a task has no ``l_gt``)."""
    terms = []
    for rs in tasks:
        if rs[0].get("l_gt") is None:
            return None
        ok = [r for r in rs if r["success"]]
        sr = len(ok) / len(rs)
        if ok:
            mean_len = statistics.fmean(float(r["resolution_length"]) for r in ok)
            terms.append(mean_len / float(rs[0]["l_gt"]) * sr)
        else:
            terms.append(0.0)
    return sum(terms) / len(terms)


def categories(values: Iterable[str]) -> list[tuple[str, str]]:
    """(value, title) of the task categories among ``values`` (``all`` left out): the household
    suite's anomaly types in their order, then any other (a world's name, as its title) in the
    order met."""
    present = list(dict.fromkeys(v for v in values if v != "all"))
    known = [(c.value, c.title) for c in Category if c.value in present]
    types = {c.value for c in Category}
    return known + [(v, v) for v in present if v not in types]


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95 % Wilson score interval of ``successes`` out of ``n`` (samples pooled over
    tasks; (0, 1) for n = 0)."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * ((p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def summarise(records: Sequence[dict[str, Any]], methods: Sequence[str]) -> tuple[Cell, ...]:
    """One cell per method and anomaly type present, plus ``all`` per method; each method's
    cell has its lift over the replan row's cell of the same type (when there is one)."""
    cells = []
    for method in methods:
        mine = [r for r in records if r["method"] == method]
        if not mine:
            continue
        for cat, _ in categories(str(r["category"]) for r in mine):
            cells.append(_cell(method, cat, [r for r in mine if r["category"] == cat]))
        cells.append(_cell(method, "all", mine))
    base = {c.category: c.sr for c in cells if c.method == REPLAN}
    return tuple(
        replace(c, lift=c.sr - base[c.category])
        if c.method not in (ORACLE, REPLAN) and c.category in base
        else c
        for c in cells
    )


def method_label(method: str, llm: str) -> str:
    if method == ORACLE:
        return f"oracle ({UPPER_BOUND})"
    if method == REPLAN:
        return f"replan ({BASELINE}: the task restated)"
    if llm == ORACLE:
        return f"{method} with the oracle LLM ({UPPER_BOUND})"
    return method


def _f(x: float | None, digits: int = 2) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def _signed(x: float | None) -> str:
    return "—" if x is None else f"{x:+.2f}"


def markdown_table(
    cells: Sequence[Cell], config: PromptingConfig, records: Sequence[Mapping[str, Any]] = ()
) -> str:
    """Table II and the extra metrics (``records``: the samples, for how they were judged)."""
    methods = list(dict.fromkeys(c.method for c in cells))
    cats = categories(c.category for c in cells)
    get = {(c.method, c.category): c for c in cells}
    fixed = " and ".join(
        name for name, on in ((ORACLE, config.oracle), (REPLAN, config.replan)) if on
    )
    sampling = (
        f"{config.samples} sample(s) per task at temperature {config.temperature:g}"
        + (f", {fixed}: 1" if fixed else "")
        if config.methods
        else "1 sample per task"
    )
    lines = [
        f"Prompting methods on {config.subject} (LLM: {config.llm}; {sampling}; "
        f"at most {config.max_rounds} LLM rounds per run). "
        "SR: success rate; ASPL = (1/n) Σ (L̄_i / L_gt,i) × SR_i; "
        "1st eff.: share of first proposals that entail an effective goal set of the task.",
        "",
        "| Method | " + " | ".join(f"{t} SR | {t} ASPL | {t} 1st eff." for _, t in cats) + " |",
        "|---|" + "---:|---:|---:|" * len(cats),
    ]
    for m in methods:
        row = [method_label(m, config.llm)]
        for cat, _ in cats:
            cell = get.get((m, cat))
            row += [_f(cell.sr), _f(cell.aspl), _f(cell.first_effective)] if cell else ["—"] * 3
        lines.append("| " + " | ".join(row) + " |")
    lifted = [m for m in methods if get.get((m, "all")) and get[(m, "all")].lift is not None]
    if lifted:
        lines += [
            "",
            "Lift over replan (SR minus the replan row's SR; replan answers every goal request "
            "with the task goal, so a lift near 0 means the planner, not the LLM, resolved the "
            "anomalies):",
            "",
            "| Method | " + " | ".join(t for _, t in cats) + " | all |",
            "|---|" + "---:|" * (len(cats) + 1),
        ]
        for m in lifted:
            row = [method_label(m, config.llm)]
            row += [_signed(get[(m, c)].lift) if (m, c) in get else "—" for c, _ in cats]
            row.append(_signed(get[(m, "all")].lift))
            lines.append("| " + " | ".join(row) + " |")
    counts = ", ".join(
        f"{get[(methods[0], c)].tasks} {c}" for c, _ in cats if (methods[0], c) in get
    )
    lines += [
        "",
        f"Per sample, over all tasks (n = {counts}):",
        "",
        "| Method | SR | SR 95 % CI | ASPL | 1st eff. | lift | syntax-error rate | repairs "
        "| tokens | LLM latency (s) | loop completion | false done |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for m in methods:
        c = get[(m, "all")]
        lines.append(
            f"| {method_label(m, config.llm)} | {_f(c.sr)} | {_f(c.sr_low)}–{_f(c.sr_high)} | "
            f"{_f(c.aspl)} | "
            f"{_f(c.first_effective)} | {_signed(c.lift)} | "
            f"{_f(c.syntax_error_rate)} | {c.repairs:.2f} | {c.tokens:.0f} | {c.latency:.2f} | "
            f"{c.completion:.2f} | {c.false_done} |"
        )
    lines += control_lines(methods, config)
    lines += ablation_lines(cells, config)
    lines += basis_lines(records)
    return "\n".join(lines) + "\n"


def basis_lines(records: Sequence[Mapping[str, Any]]) -> list[str]:
    """What a world's samples were judged on, when some had no truth to judge on (the suite's
    are judged on the simulator's true state: nothing to say)."""
    perceived = sum(r.get("basis") == "perceived" for r in records)
    if not perceived:
        return []
    return [
        "",
        f"{perceived} of {len(records)} samples were judged on what the robot perceived (their "
        "world has no truth to judge on): their verdicts are perceived, not true.",
    ]


def control_lines(methods: Sequence[str], config: PromptingConfig) -> list[str]:
    """Which row each method's row is compared with (a claim that the model helped holds only
    against its control on the same tasks and seeds), and how candidates were scored."""
    named = [m for m in methods if m in REGISTRY]
    if not named:
        return []
    lines = ["", "Each row is compared with (its control first):", ""]
    lines += ["| Method | compared with |", "|---|---|"]
    for m in named:
        present = [c for c in controls(m) if c in methods or (c == REPLAN and config.replan)]
        shown = ", ".join(f"{c}" + ("" if c in present else " (not run here)") for c in controls(m))
        lines.append(f"| {m} | {shown} |")
    if any(REGISTRY[m].chooser in ("model", "prior") for m in named):
        lines += ["", f"Candidates scored by `{config.scoring}` (`--scoring`)."]
    return lines


def ablation_lines(cells: Sequence[Cell], config: PromptingConfig) -> list[str]:
    """SR over all tasks (with its interval) of each method under each variant of the assists,
    when there is more than one: what each assist adds, alone and together."""
    shown = variants(config)
    if len(shown) < 2 or not config.methods:
        return []
    get = {(c.method, c.category): c for c in cells}
    lines = [
        "",
        "Assists (SR over all tasks, 95 % interval; paper: the goals parsed and syntax-checked "
        "only; assisted: every assist):",
        "",
        "| Method | " + " | ".join(a.label for a in shown) + " |",
        "|---|" + "---:|" * len(shown),
    ]
    for m in config.methods:
        row = [m]
        for a in shown:
            c = get.get((row_id(m, a), "all"))
            row.append(f"{c.sr:.2f} ({c.sr_low:.2f}–{c.sr_high:.2f})" if c else "—")
        lines.append("| " + " | ".join(row) + " |")
    return lines


def write_outputs(
    records: Sequence[dict[str, Any]], cells: Sequence[Cell], config: PromptingConfig
) -> tuple[Path, ...]:
    out = config.out_dir
    out.mkdir(parents=True, exist_ok=True)
    md = atomic_write(out / "prompting.md", markdown_table(cells, config, records))
    summary = write_csv(
        out / "prompting.csv",
        [{**asdict(c), "label": method_label(c.method, config.llm)} for c in cells],
    )
    samples = write_csv(
        out / "prompting_samples.csv", [{k: v for k, v in r.items() if k != "key"} for r in records]
    )
    about = {
        "llm": config.llm,
        "methods": list(config.methods),
        "oracle": config.oracle,
        "replan": config.replan,
        "measures_llm": config.measures_llm,
        "protocols": [a.label for a in variants(config)],
        "votes": config.votes,
        "samples": config.samples,
        "temperature": config.temperature,
        "max_rounds": config.max_rounds,
        "tasks": sorted({str(r["task"]) for r in records}),
        **({} if config.on_suite else {"world": config.world}),
    }
    table = [{**asdict(c), "label": method_label(c.method, config.llm)} for c in cells]
    js = atomic_write(
        out / "prompting.json", json.dumps({"config": about, "cells": table}, indent=2) + "\n"
    )
    png = out / "prompting.png"
    plot(cells, config, png)
    from llmpas.experiments.prompting_page import write_page

    page = write_page(records, cells, config)
    return (md, summary, js, samples, png, page)


def plot(cells: Sequence[Cell], config: PromptingConfig, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(dict.fromkeys(c.method for c in cells))
    cats = categories(c.category for c in cells)
    get = {(c.method, c.category): c for c in cells}
    width = 0.8 / max(1, len(methods))
    fig, axes = plt.subplots(1, 2, figsize=(4.0 + 1.2 * len(cats) * max(1, len(methods)), 5.0))
    for ax, metric, label in zip(axes, ("sr", "aspl"), ("SR", "ASPL"), strict=True):
        top = 0.0
        for i, m in enumerate(methods):
            xs = [j + (i - (len(methods) - 1) / 2) * width for j in range(len(cats))]
            ys = [
                float(getattr(get[(m, c)], metric) or 0.0) if (m, c) in get else 0.0
                for c, _ in cats
            ]
            top = max(top, *ys)
            name = method_label(m, config.llm)
            bars = ax.bar(
                xs, ys, width * 0.95, label=name, hatch="//" if UPPER_BOUND in name else None
            )
            ax.bar_label(bars, labels=[f"{y:.2f}" for y in ys], fontsize=7, padding=1)
        ax.set_xticks(range(len(cats)), [t for _, t in cats])
        ax.set_ylim(0, max(1.12, top * 1.15))
        ax.set_ylabel(label)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_title(f"Success rate (LLM: {config.llm})", fontsize=10)
    axes[1].set_title("ASPL = mean (L̄ / L_gt) × SR", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=min(4, len(methods)))
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    save_figure(fig, path)
    plt.close(fig)
