"""The prompting experiment's settings: :class:`PromptingConfig` (one run), :class:`Payload`
(one job) and the table's rows (:func:`plan_rows`: the oracle, replan, then each method under each
protocol and assist variant). The experiment itself: :mod:`llmpas.experiments.prompting`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from llmpas.experiments.jobs import (
    ExecutorSpec,
)
from llmpas.experiments.suite import (
    HALVES,
    SUITE_DIR,
)
from llmpas.experiments.worlds import LoopConfig
from llmpas.reasoning.assists import PROTOCOLS, Assists, ablation, parse_assists
from llmpas.reasoning.backends.backend_registry import BACKENDS, choices
from llmpas.reasoning.methods import (
    DECODINGS,
    METHODS,
    SCORINGS,
    method_names,
)
from llmpas.reasoning.replan import REPLAN
from llmpas.reasoning.truth_oracle import ORACLE
from llmpas.system import SweepBudget

UPPER_BOUND = "upper bound"
BASELINE = "no reasoning"
REPLAN_VERSION = "replan-2"  # part of the replan row's cache keys: bump when its answers change
SUITE_WORLD = "household"
"""The world whose tasks are the anomaly suite's (``--suite``): the default ``--world``. Any other
world's tasks are its shipped scenarios (:mod:`llmpas.experiments.world_tasks`)."""


@dataclass(frozen=True)
class PromptingConfig:
    """One run of the experiment.

    ``llm``: ``oracle`` | ``replay:DIR`` | ``openai:MODEL[@URL]`` | ``llama-cpp[:PATH]`` (as
    ``llmpas run --llm``); ``record``: a cassette folder the answers are recorded into.
    ``methods``: prompting methods (of :data:`llmpas.reasoning.methods.METHODS`); ``oracle``
    adds the upper-bound row, ``replan`` the no-reasoning baseline row (and the lifts).
    ``tasks``: only these task names (default: the whole suite); ``measures_llm``: only the
    tasks marked ``measures_llm`` (the suite that measures the LLM). ``world``: the
    household's anomaly suite (:data:`SUITE_WORLD`), or any registered world (or
    ``package.module:WORLD``) whose shipped scenarios are then the tasks (``tasks``: their
    names).
    """

    llm: str = "llama-cpp"
    methods: tuple[str, ...] = METHODS
    oracle: bool = True
    replan: bool = True
    measures_llm: bool = False
    half: str = ""  # development | rest: only that half of the tasks (suite.development_half)
    samples: int = 3
    temperature: float = 0.7
    seed: int = 0
    decoding: str = "grammar"
    repairs: int = 2
    max_rounds: int = 3
    max_tokens: int = 256
    max_time: float = 600.0  # planner safety net per plan (counted limits decide)
    suite: Path = SUITE_DIR
    tasks: tuple[str, ...] | None = None
    record: Path | None = None
    jobs: int = 1
    out_dir: Path = Path("results/prompting")
    executor: ExecutorSpec = field(default_factory=ExecutorSpec)
    keep_runs: bool = False  # each run's folder (loop.json, index.html) under out_dir/runs
    protocols: tuple[str, ...] = ("assisted",)  # paper | assisted | assists joined by "+"
    ablation: bool = False  # also: no assist, each assist alone, all (the methods' rows)
    votes: int = 1  # self-consistency: sampled answers per consultation (1: off)
    # places one object-loss consultation's sweep searches at most (1: one place a
    # consultation, the loop before #35's sweeps)
    sweep_places: int = SweepBudget().places
    scoring: str = "mean"  # how the choosing methods score candidates (choose.Scoring)
    world: str = SUITE_WORLD  # another world: its shipped scenarios are the tasks

    def __post_init__(self) -> None:
        self._check_world()
        if self.scoring not in SCORINGS:
            raise ValueError(f"scoring must be one of {', '.join(SCORINGS)}; got {self.scoring!r}")
        if not self.protocols:
            raise ValueError("protocols: give at least one (paper, assisted)")
        for spec in self.protocols:
            parse_assists(spec)  # ValueError naming an unknown assist
        if not 1 <= self.votes <= 16:
            raise ValueError(f"votes must be in [1, 16], got {self.votes}")
        if self.half not in ("", *HALVES):
            raise ValueError(f"half must be one of {', '.join(HALVES)}; got {self.half!r}")
        known = method_names()
        bad = [m for m in self.methods if m not in known]
        if bad:
            raise ValueError(f"unknown method {bad[0]!r}; methods: {', '.join(known)}")
        if len(set(self.methods)) != len(self.methods):
            raise ValueError("a method is listed twice")
        if not self.methods and not self.oracle and not self.replan:
            raise ValueError("nothing to run: give methods or keep the oracle or replan row")
        if self.samples < 1:
            raise ValueError(f"samples must be >= 1, got {self.samples}")
        if not 0.0 <= self.temperature <= 2.0:
            raise ValueError(f"temperature must be in [0, 2], got {self.temperature}")
        if self.decoding not in DECODINGS:
            raise ValueError(f"decoding must be one of {', '.join(DECODINGS)}")
        if self.repairs < 0:
            raise ValueError(f"repairs must be >= 0, got {self.repairs}")
        if self.max_rounds < 1:
            raise ValueError(f"max_rounds must be >= 1, got {self.max_rounds}")
        if self.sweep_places < 1:
            raise ValueError(f"sweep_places must be >= 1, got {self.sweep_places}")
        if self.max_tokens < 1:
            raise ValueError(f"max_tokens must be >= 1, got {self.max_tokens}")
        if self.max_time <= 0:
            raise ValueError(f"max_time must be > 0, got {self.max_time}")
        if self.jobs < 1:
            raise ValueError(f"jobs must be >= 1, got {self.jobs}")
        if self.tasks is not None and not self.tasks:
            raise ValueError("tasks: give at least one task name (or None for all)")
        if not self.llm.strip():
            raise ValueError(f"llm: give a backend ({choices(('oracle', *BACKENDS))})")

    def _check_world(self) -> None:
        """The suite's own options apply to the suite only."""
        if not self.world.strip():
            raise ValueError("--world: give a world's name")
        if self.on_suite:
            return
        for option, given in (
            ("--suite", self.suite != SUITE_DIR),
            ("--measures-llm", self.measures_llm),
            ("--half", bool(self.half)),
        ):
            if given:
                raise ValueError(
                    f"{option}: the household suite's option; --world {self.world} runs the "
                    "world's scenarios (--tasks: their names)"
                )

    @property
    def on_suite(self) -> bool:
        """Whether the tasks are the anomaly suite's (else the world's shipped scenarios)."""
        return self.world == SUITE_WORLD

    @property
    def subject(self) -> str:
        """What the tasks are, as the tables say it."""
        return "the household anomaly suite" if self.on_suite else f"the {self.world} scenarios"


@dataclass(frozen=True)
class Payload:
    """One job: run ``method`` (``oracle``: the upper bound; ``replan``: the no-reasoning
    baseline) on one task file, sample ``sample``.
    The file's content travels with the job (a cluster's workers need not have the file)."""

    task_file: str
    method: str
    sample: int
    llm: str  # the backend spec ("oracle" / "replan" for those rows)
    record: str | None
    loop: LoopConfig
    task_data: bytes | None = None  # the task file's content (None: read ``task_file``)
    keep: str | None = None  # the folder this run is kept in
    row: str = ""  # the table's row ("": ``method``)
    world: str = SUITE_WORLD  # another world: ``task_file`` is its scenario's name


def variants(config: PromptingConfig) -> tuple[Assists, ...]:
    """The assists the methods run with, in order (each protocol, then the ablation's)."""
    out = [parse_assists(p) for p in config.protocols]
    out += list(ablation()) if config.ablation else []
    return tuple(dict.fromkeys(out))


def row_id(method: str, assists: Assists) -> str:
    """A method's row under ``assists``: the method's name in the assisted protocol (today's
    loop), else ``method [label]``."""
    return method if assists == PROTOCOLS["assisted"] else f"{method} [{assists.label}]"


def plan_rows(config: PromptingConfig) -> list[tuple[str, str, Assists]]:
    """(row, method, assists) of the table, in order: the oracle, replan, then the methods
    under each variant."""
    fixed = [
        (m, m, Assists()) for m, on in ((ORACLE, config.oracle), (REPLAN, config.replan)) if on
    ]
    methods = [(row_id(m, a), m, a) for a in variants(config) for m in config.methods]
    return fixed + methods


def rows(config: PromptingConfig) -> list[str]:
    """The table's rows, in order: the oracle, replan, then the methods (per variant)."""
    return [row for row, _, _ in plan_rows(config)]
