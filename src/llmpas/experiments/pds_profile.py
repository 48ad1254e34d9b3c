"""Where a planner's CPU goes on a PDDLStream script: ``llmpas bench pddlstream DIR --profile``.

Each profiled trial runs the script under :mod:`cProfile` with a CPU clock
(``time.process_time``), started by a prelude that changes nothing the planner does; the same
prelude, from outside, counts every stream call per stream (calls, calls with an output, CPU)
by wrapping the one method through which each planner calls a stream's implementation
(llmpas: ``StreamStore.call``; PDDLStream: ``StreamInstance.next_results`` and
``FunctionInstance.next_results``), and measures its child processes' CPU (Fast Downward: for
llmpas its translator, a forked child, is measured apart from its searches; PDDLStream
translates in its own process). Nothing of PDDLStream's source is edited or copied: the
prelude patches the installed classes at run time, by name. A profiler the script itself
starts (PDDLStream's ``Profiler``, used by several of its examples) would take the place of
this one, so ``cProfile.Profile`` is made inert for the script (it prints an empty profile).

The profile is then read here, in llmpas's own process, and split into categories by where the
CPU was *entered* from outside a category's functions (a call from one of its own functions is
not counted twice):

- ``instantiation``: the optimistic stream instances built for each search (llmpas:
  ``optimistic_instances``; PDDLStream: ``optimistic_process_streams``);
- ``translation``: the task written, grounded and turned into SAS+ (llmpas: ``compile_task``
  and its translator's child process; PDDLStream: ``task_from_domain_problem``,
  ``instantiate_task``, ``sas_from_instantiated``, ``write_sas_task``);
- ``search``: Fast Downward's search processes;
- ``streams``: the user's stream implementations, per stream; ``motion``: the part of it in
  motion planners (``motion_planners`` or a ``pybullet_tools`` ``plan_*motion*`` function);
- ``other``: the rest of ``solve`` (each planner's own bookkeeping).

Counts come from the same profile (calls of named functions): Fast Downward searches and
translations, optimistic plans (plans over optimistic values whose streams were evaluated) and
skeletons (llmpas: kept plans drawn again; PDDLStream: skeletons queued), and iterations.

cProfile slows Python code down (C code, Fast Downward's search and translator children much
less), so a profiled trial's CPU is higher than an unprofiled one; the split is what it is for.
"""

from __future__ import annotations

import json
import pstats
import re
import statistics
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

#: Environment variable naming the folder a profiled trial writes its profile to.
ENV = "LLMPAS_PDS_PROFILE"

_COMMON = r"""
import cProfile as _cP, json as _js, os as _os, resource as _rs, signal as _sg, time as _tm
_PDIR = _os.environ["LLMPAS_PDS_PROFILE"]
_STREAMS, _KIDS = {}, {"translate": 0.0}
def _kids():
    r = _rs.getrusage(_rs.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime
def _wrap_stream(cls, attr, name_of, ok_of):
    orig = getattr(cls, attr)
    def _stream_call(self, *a, **k):
        t, ok = _tm.process_time(), False
        try:
            out = orig(self, *a, **k)
            ok = ok_of(out)
            return out
        finally:
            s = _STREAMS.setdefault(name_of(self, a), [0, 0, 0.0])
            s[0] += 1
            s[1] += bool(ok)
            s[2] += _tm.process_time() - t
    setattr(cls, attr, _stream_call)
def _term(signum, frame):
    raise SystemExit(128 + signum)
_sg.signal(_sg.SIGTERM, _term)
_PROF = _cP.Profile(_tm.process_time)
class _Nested:  # a profiler the script starts would replace this one: it profiles nothing
    def __init__(self, *a, **k):
        self.stats = {}
    def enable(self, *a, **k):
        pass
    def disable(self):
        pass
    def create_stats(self):
        self.stats = {("~", 0, "(profiled by llmpas bench --profile)"): (1, 1, 0.0, 0.0, {})}
    def __enter__(self):
        return self
    def __exit__(self, *exc):
        return False
_cP.Profile = _Nested
def _profiled(fn):
    _PROF.enable()
    try:
        return fn()
    finally:
        _PROF.disable()
        _PROF.dump_stats(_os.path.join(_PDIR, "profile.pstats"))
        with open(_os.path.join(_PDIR, "profile.json"), "w") as f:
            _js.dump({"streams": _STREAMS, "translate_children": _KIDS["translate"],
                      "children": _kids()}, f)
"""

#: llmpas: the stream store's calls and the translator's forked child, measured apart.
LLMPAS_PRELUDE = (
    _COMMON
    + r"""
from llmpas.planning import instances as _inst, downward as _dw
_wrap_stream(_inst.StreamStore, "call", lambda self, a: a[0].bound.schema.name,
             lambda out: out is not None)
_orig_translate = _dw._translate
def _translate_measured(*a, **k):
    before = _kids()
    try:
        return _orig_translate(*a, **k)
    finally:
        _KIDS["translate"] += _kids() - before
_dw._translate = _translate_measured
"""
)

#: PDDLStream: its stream, function and predicate instances' calls of the implementations.
PDDLSTREAM_PRELUDE = (
    _COMMON
    + r"""
from pddlstream.language import stream as _st, function as _fn
def _ok(out):
    return any(r.is_successful() for r in out[0])
_wrap_stream(_st.StreamInstance, "next_results", lambda self, a: self.external.name, _ok)
_wrap_stream(_fn.FunctionInstance, "next_results", lambda self, a: self.external.name, _ok)
"""
)

Func = tuple[str, int, str]  # pstats' key: file, line, function name
Match = Callable[[Func], bool]


def _named(*pairs: tuple[str, str]) -> Match:
    """Functions named ``name`` in a file whose path ends with ``suffix``."""

    def match(func: Func) -> bool:
        path = func[0].replace("\\", "/")
        return any(func[2] == name and path.endswith(suffix) for suffix, name in pairs)

    return match


_MOTION_FN = re.compile(r"^plan_.*motion")


def _motion(func: Func) -> bool:
    path = func[0].replace("\\", "/")
    if "/motion_planners/" in path:  # its functions, not its imports or class bodies
        return func[2][:1].islower()
    return path.endswith("pybullet_tools/utils.py") and bool(_MOTION_FN.match(func[2]))


_STREAM_CALL = _named(("<string>", "_stream_call"))


@dataclass(frozen=True)
class Rules:
    """Which functions make up each category and count, for one planner."""

    solve: Match
    instantiation: Match
    translation: Match
    searches: Match
    translations: Match
    optimistic_plans: tuple[Match, Match | None]  # (function, only calls from these) or None
    skeletons: Match
    iterations: tuple[Match, Match | None]


RULES: Mapping[str, Rules] = {
    "llmpas": Rules(
        solve=_named(("llmpas/pddlstream/solving.py", "solve")),
        instantiation=_named(("llmpas/planning/instances.py", "optimistic_instances")),
        translation=_named(
            ("llmpas/planning/compile.py", "compile_task"),
            ("llmpas/planning/downward.py", "_translate"),
            ("<string>", "_translate_measured"),
        ),
        searches=_named(("llmpas/planning/downward.py", "_search")),
        translations=_named(("<string>", "_translate_measured")),
        optimistic_plans=(
            _named(("llmpas/planning/skeletons.py", "evaluate_streams")),
            _named(("llmpas/planning/tamp.py", "_focused")),
        ),
        skeletons=_named(("llmpas/planning/skeletons.py", "resample")),
        iterations=(
            _named(("llmpas/planning/planner_run.py", "patience_left")),
            None,
        ),
    ),
    "pddlstream": Rules(
        solve=_named(
            ("pddlstream/algorithms/meta.py", "solve"),
            ("pddlstream/algorithms/focused.py", "solve_abstract"),
            ("pddlstream/algorithms/incremental.py", "solve_incremental"),
        ),
        instantiation=_named(("pddlstream/algorithms/refinement.py", "optimistic_process_streams")),
        translation=_named(
            ("pddlstream/algorithms/downward.py", "task_from_domain_problem"),
            ("pddlstream/algorithms/downward.py", "get_problem"),
            ("pddlstream/algorithms/instantiate_task.py", "instantiate_task"),
            ("pddlstream/algorithms/instantiate_task.py", "sas_from_instantiated"),
            ("pddlstream/algorithms/instantiate_task.py", "write_sas_task"),
        ),
        searches=_named(("pddlstream/algorithms/downward.py", "run_search")),
        translations=_named(("pddlstream/algorithms/instantiate_task.py", "sas_from_instantiated")),
        optimistic_plans=(
            _named(
                ("pddlstream/algorithms/skeleton.py", "new_skeleton"),
                ("pddlstream/algorithms/disabled.py", "process_stream_plan"),
            ),
            None,
        ),
        skeletons=_named(("pddlstream/algorithms/skeleton.py", "new_skeleton")),
        iterations=(
            _named(("pddlstream/algorithms/refinement.py", "iterative_plan_streams")),
            None,
        ),
    ),
}


@dataclass(frozen=True)
class StreamCount:
    name: str
    calls: int
    successes: int
    cpu: float


@dataclass(frozen=True)
class Profile:
    """One profiled trial, CPU seconds (module docstring)."""

    solve: float  # solve's own process and its Fast Downward children
    instantiation: float
    translation: float
    search: float
    streams: float
    motion: float
    other: float
    searches: int
    translations: int
    optimistic_plans: int
    skeletons: int
    iterations: int
    per_stream: tuple[StreamCount, ...] = field(default=())

    def __post_init__(self) -> None:
        if min(self.solve, self.search, self.streams, self.motion) < 0:
            raise ValueError("CPU seconds must be >= 0")

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Profile:
        streams = tuple(StreamCount(**s) for s in d.get("per_stream", ()))
        return cls(**{**d, "per_stream": streams})


CATEGORIES = ("instantiation", "translation", "search", "streams", "other")


def entered(
    stats: Mapping[Func, Any], match: Match, callers_only: Match | None = None
) -> tuple[float, int]:
    """(CPU, calls) of the functions ``match`` selects, counted where they are entered from a
    function it does not select (or, with ``callers_only``, from one that selects)."""
    cpu, calls = 0.0, 0
    for func, (_cc, nc, _tt, ct, callers) in stats.items():
        if not match(func):
            continue
        if callers_only is None:  # calls from no recorded caller: entered from outside
            calls += nc - sum(int(v[0]) for v in callers.values())
            cpu += max(0.0, ct - sum(float(v[3]) for v in callers.values()))
        for caller, value in callers.items():
            inside = match(caller)
            if (callers_only is None and not inside) or (callers_only and callers_only(caller)):
                calls += int(value[0])
                cpu += float(value[3])
    return cpu, calls


def outermost(stats: Mapping[Func, Any], match: Match) -> float:
    """The CPU of the outermost of the functions ``match`` selects: the largest of their
    entered times (one may call another through functions it does not select, as PDDLStream's
    ``solve`` calls ``solve_abstract`` through ``solve_adaptive``: a sum would count it twice)."""
    return max((entered(stats, _only(f))[0] for f in stats if match(f)), default=0.0)


def _only(func: Func) -> Match:
    return lambda f: f == func


def read_profile(folder: Path, planner: str) -> Profile | None:
    """The profile a trial left in ``folder`` (None if it left none, e.g. killed hard)."""
    stats_file, extra_file = folder / "profile.pstats", folder / "profile.json"
    if not (stats_file.is_file() and extra_file.is_file()):
        return None
    stats: Mapping[Func, Any] = pstats.Stats(str(stats_file)).stats  # type: ignore[attr-defined]
    extra = json.loads(extra_file.read_text())
    rules = RULES[planner]
    own_solve = outermost(stats, rules.solve)
    inst, _ = entered(stats, rules.instantiation)
    trans, _ = entered(stats, rules.translation)
    streams, _ = entered(stats, _STREAM_CALL)
    motion, _ = entered(stats, _motion)
    children = float(extra.get("children", 0.0))
    trans_kids = float(extra.get("translate_children", 0.0))
    per_stream = tuple(
        sorted(
            (
                StreamCount(k, int(v[0]), int(v[1]), round(float(v[2]), 4))
                for k, v in extra["streams"].items()
            ),
            key=lambda s: -s.cpu,
        )
    )
    return Profile(
        solve=round(own_solve + children, 4),
        instantiation=round(inst, 4),
        translation=round(trans + trans_kids, 4),
        search=round(max(0.0, children - trans_kids), 4),
        streams=round(streams, 4),
        motion=round(motion, 4),
        other=round(max(0.0, own_solve - inst - trans - streams), 4),
        searches=entered(stats, rules.searches)[1],
        translations=entered(stats, rules.translations)[1],
        optimistic_plans=entered(stats, *rules.optimistic_plans)[1],
        skeletons=entered(stats, rules.skeletons)[1],
        iterations=entered(stats, *rules.iterations)[1],
        per_stream=per_stream,
    )


# ------------------------------------------------------------------------------------ report

_FIGURES = (
    ("solve CPU s", "solve"),
    ("  instantiation", "instantiation"),
    ("  translation", "translation"),
    ("  Fast Downward search", "search"),
    ("  stream evaluation", "streams"),
    ("    of which motion planning", "motion"),
    ("  other (the planner's own)", "other"),
    ("Fast Downward searches", "searches"),
    ("translations", "translations"),
    ("optimistic plans evaluated", "optimistic_plans"),
    ("skeletons", "skeletons"),
    ("iterations", "iterations"),
)


def _med(values: Sequence[float]) -> float:
    return statistics.median(values) if values else 0.0


def profile_table(instance: str, by_planner: Mapping[str, Sequence[Profile]]) -> str:
    """Markdown: the medians of each figure per planner, then the streams."""
    planners = list(by_planner)
    lines = [
        f"### `{instance}`",
        "",
        "| figure (median over profiled seeds) | " + " | ".join(planners) + " |",
        "|---|" + "---:|" * len(planners),
    ]
    for label, attr in _FIGURES:
        cells = []
        for p in planners:
            vals = [float(getattr(x, attr)) for x in by_planner[p]]
            cells.append(
                f"{_med(vals):.2f}"
                if "CPU" in label or attr in CATEGORIES or attr == "motion"
                else f"{_med(vals):g}"
            )
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", "| stream | planner | calls | with output | CPU s |", "|---|---|---:|---:|---:|"]
    for p in planners:
        names = {s.name for prof in by_planner[p] for s in prof.per_stream}
        rows = []
        for name in names:
            got = [
                next((s for s in prof.per_stream if s.name == name), None) for prof in by_planner[p]
            ]
            calls = _med([s.calls if s else 0 for s in got])
            ok = _med([s.successes if s else 0 for s in got])
            cpu = _med([s.cpu if s else 0.0 for s in got])
            rows.append((cpu, f"| {name} | {p} | {calls:g} | {ok:g} | {cpu:.2f} |"))
        lines += [r for _, r in sorted(rows, key=lambda r: -r[0])]
    return "\n".join(lines) + "\n"


def profile_plot(instance: str, by_planner: Mapping[str, Sequence[Profile]], path: Path) -> None:
    """Stacked bars, one per planner: the median CPU of each category."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from llmpas.files import save_figure

    planners = list(by_planner)
    colors = {"instantiation": "tab:purple", "translation": "tab:orange", "search": "tab:red",
              "streams": "tab:green", "other": "tab:gray"}  # fmt: skip
    fig, ax = plt.subplots(figsize=(7.0, 1.2 + 0.8 * len(planners)))
    for i, p in enumerate(planners):
        left = 0.0
        for cat in CATEGORIES:
            v = _med([float(getattr(x, cat)) for x in by_planner[p]])
            ax.barh(i, v, left=left, color=colors[cat], label=cat if i == 0 else None)
            left += v
    ax.set_yticks(range(len(planners)))
    ax.set_yticklabels(planners)
    ax.set_xlabel("solve CPU s (median over profiled seeds; under cProfile)")
    ax.set_title(instance if len(instance) < 60 else "..." + instance[-57:], fontsize=9)
    ax.legend(fontsize=7, ncol=len(CATEGORIES), loc="upper center", bbox_to_anchor=(0.5, -0.35))
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def slug(instance: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "-", instance).strip("-").lower()[:80]


__all__ = [
    "CATEGORIES",
    "ENV",
    "LLMPAS_PRELUDE",
    "PDDLSTREAM_PRELUDE",
    "Profile",
    "StreamCount",
    "entered",
    "profile_plot",
    "profile_table",
    "read_profile",
    "slug",
]
