"""``llmpas bench knowledge``: what a model knows, where the loop cannot hide it.

**Recorded once, no model.** For each task of a suite, the closed loop runs to its first
consultation and stops there (:func:`~llmpas.system.probe.first_consultation`): the anomaly, the
prompt's situation and the candidate goal sets the loop's checks accept are recorded
(``OUT/record/``), each candidate marked effective or not by the task's ``effective`` sets, as
the judge reads a first proposal (:func:`~llmpas.experiments.effective.is_effective`).

**Ranked by any model.** ``--llm`` (any backend: the offline model, an OpenAI-compatible server,
a replayed cassette) ranks the checked candidates with each method of ``--methods``
(``flp-choose``: after the first look, each candidate scored as the model's answer; ``prior``:
the same prompt without the anomaly's evidence and without the history) and each scoring of
``--scorings``, exactly as the loop would (:func:`~llmpas.reasoning.choose.rank`). Every ranking
is cached (``OUT/cache``): the same command resumes.

**Measured.** Per task, the rank of the first effective candidate. Per method and scoring: the
mean reciprocal rank (MRR) and top-1 against the shuffled order's exact expectation (a uniform
order of ``n`` candidates with ``k`` effective: P(R = r) = C(n - r, k - 1) / C(n, k)), a one-sided
Wilcoxon signed-rank test of the rank against its expectation and an exact Poisson-binomial test
of top-1 (each task's chance k/n); against ``prior``, a paired Wilcoxon test on the ranks and an
exact McNemar test on top-1. Tasks whose checked candidates hold no effective one are listed
apart (nothing to find). Writes ``knowledge.md``, ``knowledge.csv`` (one row per task and
ranking) and ``knowledge.png``.
"""

from __future__ import annotations

import argparse
import base64
import math
import pickle
import statistics
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.experiments.effective import is_effective, lost_object
from llmpas.experiments.harness import Harnessed, Shared, SharedOptions, run_trials
from llmpas.experiments.jobs import ExecutorSpec, Job, add_llm_argument, backend
from llmpas.experiments.suite import SUITE_DIR, SuiteTask, development_half, load_suite, load_task
from llmpas.files import atomic_write, save_figure, write_csv
from llmpas.options import positive_int
from llmpas.reasoning.choose import HOWS, rank
from llmpas.reasoning.methods import SCORINGS, MethodConfig

METHODS = ("flp-choose", "prior")
CONTROL = "prior"  # the paired control of the model's own ranking


@dataclass(frozen=True)
class Recorded:
    """One task's first consultation: the checked candidates (as text) and which are effective;
    ``data``: the situation and candidates, pickled (what a ranking needs)."""

    task: str
    category: str
    anomaly: str
    candidates: tuple[str, ...]
    effective: tuple[bool, ...]
    data: str  # base64 of the pickled (situation, candidates)

    @property
    def informative(self) -> bool:
        """Some candidate is effective (else there is nothing to find)."""
        return any(self.effective)


def record_job(payload: tuple[str, str]) -> dict[str, Any]:
    """Record one task's first consultation (module level: it may run in another process)."""
    from llmpas.system.catalog import load_world
    from llmpas.system.probe import first_consultation
    from llmpas.system.settings import LoopSettings
    from llmpas.worlds.api import RunOptions

    task_file, _ = payload
    task = load_task(task_file)
    with load_world("household").open(task.scenario, RunOptions()) as session:
        got = first_consultation(session, LoopSettings(success=task.success))
    if got is None:
        return {"task": task.name, "category": task.category.value, "anomaly": "", "none": True}
    lost = lost_object(got.situation.constraint)
    sets = task.effective_sets()
    places = task.search_places()
    effective = [is_effective(c, sets, lost, places) for c in got.checked]
    situation = replace(got.situation, calls=dict(got.situation.calls))  # picklable
    data = base64.b64encode(pickle.dumps((situation, got.checked))).decode()
    return {
        "task": task.name,
        "category": task.category.value,
        "anomaly": got.anomaly,
        "candidates": [" ".join(map(str, c)) for c in got.checked],
        "effective": effective,
        "data": data,
    }


def rank_job(payload: tuple[str, str, str, str]) -> dict[str, Any]:
    """One ranking of one recorded consultation: (record's data, task, method, scoring) with
    the LLM of the spec in the job key's ``llm`` (module level: it may run elsewhere)."""
    data, task, how, spec = payload
    method, _, scoring = how.partition("/")
    situation, checked = pickle.loads(base64.b64decode(data))
    config = MethodConfig(method=method, scoring=scoring, task=task, seed=0)
    started = time.perf_counter()
    ranked, _, _ = rank(situation, backend(spec), checked, config)
    order = [checked.index(r.goals) for r in ranked]
    return {"order": order, "seconds": round(time.perf_counter() - started, 3)}


# -------------------------------------------------------------------------------- statistics


def first_effective(order: Sequence[int], effective: Sequence[bool]) -> int:
    """The 1-based rank of the first effective candidate in ``order``."""
    return next(i for i, c in enumerate(order, 1) if effective[c])


def shuffled_expectation(n: int, k: int) -> tuple[float, float, float]:
    """Under a uniform order of ``n`` candidates with ``k`` effective: the expected rank of the
    first effective one, its expected reciprocal, and the chance it is first."""
    total = math.comb(n, k)
    probs = [math.comb(n - r, k - 1) / total for r in range(1, n - k + 2)]
    mean_rank = sum(r * p for r, p in enumerate(probs, 1))
    mean_rr = sum(p / r for r, p in enumerate(probs, 1))
    return mean_rank, mean_rr, k / n


@dataclass(frozen=True)
class Row:
    """One method and scoring over a set of tasks."""

    how: str
    tasks: int
    mrr: float
    mrr_shuffled: float
    top1: int
    top1_shuffled: float
    p_rank: float  # Wilcoxon, rank below its shuffled expectation
    p_top1: float  # exact Poisson binomial, top-1 above chance
    p_rank_prior: float | None  # paired Wilcoxon against prior (None: no prior row)
    p_top1_prior: float | None  # exact McNemar against prior


def wilcoxon_less(differences: Sequence[float]) -> float:
    """One-sided Wilcoxon signed-rank p-value that the differences lie below 0 (1.0 when every
    difference is 0: no evidence)."""
    from scipy.stats import wilcoxon

    nonzero = [d for d in differences if abs(d) > 1e-12]
    if not nonzero:
        return 1.0
    return float(wilcoxon(nonzero, alternative="less").pvalue)


def poisson_binomial_at_least(successes: int, chances: Sequence[float]) -> float:
    """P(at least ``successes`` top-1 hits) when task i's hit has chance ``chances[i]``."""
    from scipy.stats import poisson_binom

    if successes <= 0:
        return 1.0
    return float(poisson_binom(list(chances)).sf(successes - 1))


def mcnemar_exact(better: int, worse: int) -> float:
    """One-sided exact McNemar p-value (``better`` discordant pairs against ``worse``)."""
    from scipy.stats import binomtest

    if better + worse == 0:
        return 1.0
    return float(binomtest(better, better + worse, 0.5, alternative="greater").pvalue)


def summarise(
    records: Sequence[Recorded], ranks: Mapping[tuple[str, str], int], hows: Sequence[str]
) -> list[Row]:
    """One :class:`Row` per ranking (``method/scoring``) over the informative records that
    every ranking ranked."""
    usable = [r for r in records if r.informative and all((r.task, h) in ranks for h in hows)]
    rows = []
    for how in hows:
        got = [ranks[r.task, how] for r in usable]
        expect = [shuffled_expectation(len(r.effective), sum(r.effective)) for r in usable]
        top1 = sum(g == 1 for g in got)
        prior = _prior(how, hows)
        p_rank_prior = p_top1_prior = None
        if prior is not None:
            theirs = [ranks[r.task, prior] for r in usable]
            p_rank_prior = wilcoxon_less([a - b for a, b in zip(got, theirs, strict=True)])
            better = sum(a == 1 and b != 1 for a, b in zip(got, theirs, strict=True))
            worse = sum(b == 1 and a != 1 for a, b in zip(got, theirs, strict=True))
            p_top1_prior = mcnemar_exact(better, worse)
        rows.append(
            Row(
                how,
                len(usable),
                statistics.fmean(1 / g for g in got) if got else 0.0,
                statistics.fmean(e[1] for e in expect) if expect else 0.0,
                top1,
                sum(e[2] for e in expect),
                wilcoxon_less([g - e[0] for g, e in zip(got, expect, strict=True)]),
                poisson_binomial_at_least(top1, [e[2] for e in expect]),
                p_rank_prior,
                p_top1_prior,
            )
        )
    return rows


def _prior(how: str, hows: Sequence[str]) -> str | None:
    """The prior row with the same scoring as ``how`` (None: ``how`` is one, or none ran)."""
    method, _, scoring = how.partition("/")
    twin = f"{CONTROL}/{scoring}"
    return twin if method != CONTROL and twin in hows else None


def _p(x: float | None) -> str:
    return "—" if x is None else f"{x:.3g}"


def table(rows: Sequence[Row]) -> list[str]:
    head = "| ranking | tasks | MRR | MRR shuffled | top-1 | top-1 shuffled | p rank vs shuffled"
    head += " | p top-1 vs shuffled | p rank vs prior | p top-1 vs prior |"
    lines = [head, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(
            f"| {r.how} | {r.tasks} | {r.mrr:.3f} | {r.mrr_shuffled:.3f} | {r.top1} "
            f"| {r.top1_shuffled:.1f} | {_p(r.p_rank)} | {_p(r.p_top1)} "
            f"| {_p(r.p_rank_prior)} | {_p(r.p_top1_prior)} |"
        )
    return lines


# -------------------------------------------------------------------------------- the command


@dataclass(frozen=True)
class KnowledgeConfig:
    llm: str
    methods: tuple[str, ...] = METHODS
    scorings: tuple[str, ...] = ("mean",)
    suite: Path = SUITE_DIR
    half: str | None = None
    tasks: tuple[str, ...] = ()
    jobs: int = 1
    out_dir: Path = Path("results/knowledge")
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)

    def __post_init__(self) -> None:
        for s in self.scorings:
            if s not in SCORINGS:
                raise ValueError(f"--scorings: {s!r} is not one of {', '.join(SCORINGS)}")
        for m in self.methods:
            if m not in METHODS:
                raise ValueError(f"--methods: {m!r} is not one of {', '.join(METHODS)}")

    @property
    def hows(self) -> tuple[str, ...]:
        return tuple(f"{m}/{s}" for m in self.methods for s in self.scorings)


def tasks_of(config: KnowledgeConfig) -> tuple[SuiteTask, ...]:
    tasks = load_suite(config.suite, config.tasks or None)
    if config.half:
        dev = development_half(load_suite(config.suite))
        tasks = tuple(t for t in tasks if (t.name in dev) == (config.half == "development"))
    return tasks


def record(config: KnowledgeConfig, console: Console) -> list[Recorded]:
    """Every task's first consultation, recorded once (cached in ``OUT/record``)."""
    tasks = tasks_of(config)
    jobs = [Job(f"record-{t.name}-{t.digest[:12]}", (t.source, t.digest)) for t in tasks]
    done = run_trials(config, jobs, record_job, "recording first consultations", console, "record")
    return [
        Recorded(
            d["task"],
            d["category"],
            d["anomaly"],
            tuple(d["candidates"]),
            tuple(d["effective"]),
            d["data"],
        )
        for d in done
        if not d.get("none")
    ]


def ranked(
    config: KnowledgeConfig, records: Sequence[Recorded], console: Console
) -> dict[tuple[str, str], tuple[int, tuple[int, ...]]]:
    """Each informative record ranked by each method and scoring with ``--llm`` (cached)."""
    jobs = []
    for r in records:
        if not r.informative:
            continue
        for how in config.hows:
            key = f"rank-{config.llm}-{how}-{r.task}-{_digest(r.data)}"
            jobs.append(Job(key, (r.data, r.task, how, config.llm), {"llm": 1}))
    done = run_trials(config, jobs, rank_job, f"ranking with {config.llm}", console)
    out = {}
    pairs = [(r, how) for r in records if r.informative for how in config.hows]
    for (r, how), d in zip(pairs, done, strict=True):
        order = tuple(int(i) for i in d["order"])
        out[r.task, how] = (first_effective(order, r.effective), order)
    return out


def _digest(text: str) -> str:
    import hashlib

    return hashlib.sha256(text.encode()).hexdigest()[:12]


def run_knowledge(config: KnowledgeConfig, console: Console | None = None) -> list[Row]:
    console = console or Console()
    records = record(config, console)
    got = ranked(config, records, console)
    ranks = {k: v[0] for k, v in got.items()}
    rows = summarise(records, ranks, config.hows)
    write_outputs(config, records, got, rows)
    console.print("\n".join(table(rows)), markup=False, highlight=False)
    return rows


def write_outputs(
    config: KnowledgeConfig,
    records: Sequence[Recorded],
    got: Mapping[tuple[str, str], tuple[int, tuple[int, ...]]],
    rows: Sequence[Row],
) -> None:
    out = config.out_dir
    blank = [r.task for r in records if not r.informative]
    text = [
        f"# What {config.llm} knows: its ranking of the checked candidates",
        "",
        f"Suite `{config.suite}`{f', {config.half} half' if config.half else ''}; "
        f"{len(records)} tasks recorded, {len(records) - len(blank)} with an effective "
        "candidate among the checked ones.",
        "",
        *table(rows),
        "",
        "Tasks whose checked candidates hold no effective one: " + (", ".join(blank) or "none"),
        "",
    ]
    atomic_write(out / "knowledge.md", "\n".join(text))
    csv_rows = []
    for r in records:
        if not r.informative:
            continue
        exp_rank, exp_rr, p1 = shuffled_expectation(len(r.effective), sum(r.effective))
        for how in config.hows:
            if (r.task, how) not in got:
                continue
            rk, order = got[r.task, how]
            csv_rows.append(
                {
                    "task": r.task,
                    "category": r.category,
                    "ranking": how,
                    "candidates": len(r.effective),
                    "effective": sum(r.effective),
                    "rank": rk,
                    "expected_rank": round(exp_rank, 3),
                    "expected_rr": round(exp_rr, 4),
                    "chance_top1": round(p1, 4),
                    "first": r.candidates[order[0]],
                }
            )
    write_csv(out / "knowledge.csv", csv_rows)
    plot(csv_rows, out / "knowledge.png")


def plot(rows: Sequence[Mapping[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for how in sorted({str(r["ranking"]) for r in rows}):
        mine = [r for r in rows if r["ranking"] == how]
        ax.scatter(
            [float(r["expected_rank"]) for r in mine],
            [int(r["rank"]) for r in mine],
            label=how,
            alpha=0.7,
        )
    top = max([float(r["expected_rank"]) for r in rows] + [int(r["rank"]) for r in rows] + [2])
    ax.plot([1, top], [1, top], color="grey", linewidth=1, label="shuffled expectation")
    ax.set_xlabel("expected rank of the first effective candidate (shuffled)")
    ax.set_ylabel("its rank by the model")
    ax.set_title("Below the line: the model ranks the right candidate higher")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_llm_argument(p)
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    p.add_argument(
        "--scorings",
        nargs="+",
        default=["mean"],
        choices=SCORINGS,
        help=f"how candidates are scored ({', '.join(HOWS)}; -words: plain words)",
    )
    p.add_argument("--suite", type=Path, default=SUITE_DIR, help="folder of task files")
    p.add_argument("--half", choices=("development", "rest"), default=None)
    p.add_argument("--tasks", nargs="+", default=[], help="only these tasks (file stems)")


def config_from(args: argparse.Namespace, shared: Shared) -> KnowledgeConfig:
    """The config of ``llmpas bench knowledge``'s options."""
    return KnowledgeConfig(
        args.llm,
        tuple(args.methods),
        tuple(args.scorings),
        args.suite,
        args.half,
        tuple(args.tasks),
        shared.jobs,
        shared.out_dir,
    )


def _run(config: KnowledgeConfig, console: Console) -> None:
    run_knowledge(config, console)
    console.print(f"wrote {config.out_dir / 'knowledge.md'}, .csv, .png")


BENCHMARK = Harnessed(
    "knowledge",
    "what a model knows: its ranking of the loop's checked candidates against a shuffled order",
    add_arguments,
    config_from,
    _run,
    SharedOptions(out="results/knowledge", jobs_type=positive_int, executor=False, out_type=Path),
)

__all__ = [
    "BENCHMARK",
    "KnowledgeConfig",
    "Recorded",
    "first_effective",
    "run_knowledge",
    "shuffled_expectation",
    "summarise",
]
