"""A small typed interface to a classical planner, implemented with Fast Downward.

Translation (PDDL -> SAS+) runs in-process with ``fast_downward.translate``; search runs the
compiled ``downward`` binary shipped by ``up-fast-downward`` as a subprocess with the SAS+ text
on stdin, under a CPU-time and address-space limit plus a wall-clock timeout.

Outcomes of a task (solved, unsolvable, limits hit, bad PDDL, planner crash) are returned as a
:class:`ClassicalPlan` with a :class:`ClassicalStatus`; an installation problem (no search
binary) raises :class:`PlannerNotFound`.

Not thread-safe: the translator keeps its options in a module global and the call redirects
``sys.stdout``/``sys.stderr`` while translating.
"""

from __future__ import annotations

import contextlib
import enum
import functools
import importlib.util
import io
import logging
import math
import os
import re
import resource
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

logger = logging.getLogger(__name__)

_AXIOMS = "axioms=approximate_negative"
_FF = f"ff({_AXIOMS})"

#: Default: greedy best-first search (lazy) with FF and preferred operators; ignores costs.
LAZY_GREEDY_FF = f"lazy_greedy([{_FF}],preferred=[{_FF}],reopen_closed=false)"
#: Cost-sensitive alternative: lazy weighted A* (w=5) with FF; g uses cost+1 (zero-cost safe).
LAZY_WASTAR_FF = f"lazy_wastar([{_FF}],preferred=[{_FF}],w=5,cost_type=plusone)"

#: Heuristics that take an ``axioms=`` option in Fast Downward 26.
_AXIOM_HEURISTICS = ("ff", "add", "hmax", "cg", "cea", "landmark_sum")
_HEURISTIC_CALL = re.compile(r"\b(" + "|".join(_AXIOM_HEURISTICS) + r")\(")
_AXIOMS_OPTION = re.compile(r"\baxioms\s*=\s*approximate_negative\b(?!_)")

#: Wall-clock slack (at most 10 % of the remaining time) before the search process is killed.
_KILL_GRACE_S = 0.25
_PIP_HINT = "pip install up-fast-downward==1.0.0"


class ClassicalStatus(enum.Enum):
    """Outcome of one planner call."""

    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"
    TIMEOUT = "timeout"
    OUT_OF_MEMORY = "out_of_memory"
    ERROR = "error"


Action = tuple[str, tuple[str, ...]]


@dataclass(frozen=True)
class ClassicalPlan:
    """Result of :meth:`ClassicalPlanner.solve`. Names are lowercase, as Fast Downward prints."""

    status: ClassicalStatus
    actions: tuple[Action, ...]
    cost: float | None
    translate_time: float
    search_time: float
    message: str = ""

    def __post_init__(self) -> None:
        solved = self.status is ClassicalStatus.SOLVED
        if self.actions and not solved:
            raise ValueError(f"a {self.status.name} result cannot carry actions")
        if (self.cost is not None) != solved:
            raise ValueError("cost must be set exactly when the status is SOLVED")

    @property
    def solved(self) -> bool:
        return self.status is ClassicalStatus.SOLVED


@dataclass(frozen=True)
class DownwardConfig:
    """Search configuration and limits for :class:`FastDownward`."""

    search: str = LAZY_GREEDY_FF
    max_time: float = 60.0  # seconds, whole call (translation + search)
    memory_mb: int = 4096  # address-space limit of the search process

    def __post_init__(self) -> None:
        _check_max_time(self.max_time)
        if self.memory_mb <= 0:
            raise ValueError(f"memory_mb must be positive, got {self.memory_mb}")
        check_axioms_option(self.search)


def _check_max_time(max_time: float) -> None:
    if not (math.isfinite(max_time) and max_time > 0):
        raise ValueError(f"max_time must be a positive number of seconds, got {max_time}")


def check_axioms_option(search: str) -> None:
    """Reject a search string whose heuristic calls lack ``axioms=approximate_negative``."""
    for match in _HEURISTIC_CALL.finditer(search):
        arguments = _call_arguments(search, match.end())
        if not _AXIOMS_OPTION.search(arguments):
            raise ValueError(
                f"heuristic {match.group(1)}(...) in search {search!r} lacks {_AXIOMS}: "
                "exact negated derived predicates blow up exponentially (23 GB measured)"
            )


def _call_arguments(text: str, start: int) -> str:
    """Text between the '(' ending at ``start`` and its matching ')' (or the end of text)."""
    depth = 1
    for index in range(start, len(text)):
        depth += {"(": 1, ")": -1}.get(text[index], 0)
        if depth == 0:
            return text[start:index]
    return text[start:]


class PlannerNotFound(RuntimeError):
    """The Fast Downward search binary is missing or not executable."""


class ClassicalPlanner(Protocol):
    def solve(
        self, domain_pddl: str, problem_pddl: str, *, max_time: float | None = None
    ) -> ClassicalPlan: ...


def find_downward_binary() -> Path:
    """Path of ``downward`` inside the installed ``up_fast_downward`` (without importing it)."""
    spec = importlib.util.find_spec("up_fast_downward")
    locations = list(spec.submodule_search_locations or []) if spec else []
    if not locations:
        raise PlannerNotFound(f"package up_fast_downward is not installed; {_PIP_HINT}")
    return Path(locations[0]) / "downward" / "builds" / "release" / "bin" / "downward"


def _failure(
    status: ClassicalStatus, message: str, translate_time: float, search_time: float = 0.0
) -> ClassicalPlan:
    return ClassicalPlan(status, (), None, translate_time, search_time, message)


class FastDownward:
    """:class:`ClassicalPlanner` running Fast Downward (translator in-process, search binary)."""

    def __init__(self, config: DownwardConfig | None = None, binary: Path | None = None):
        self.config = config if config is not None else DownwardConfig()
        self._binary_override = binary

    @functools.cached_property
    def binary(self) -> Path:
        """The search binary; looked up once per instance. Raises :class:`PlannerNotFound`."""
        path = self._binary_override or find_downward_binary()
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise PlannerNotFound(f"Fast Downward search binary not found at {path}; {_PIP_HINT}")
        return path

    def solve(
        self, domain_pddl: str, problem_pddl: str, *, max_time: float | None = None
    ) -> ClassicalPlan:
        """Plan for the PDDL texts; ``max_time`` (seconds) overrides ``config.max_time``."""
        binary = self.binary
        budget = self.config.max_time if max_time is None else max_time
        _check_max_time(budget)
        deadline = time.monotonic() + budget
        with tempfile.TemporaryDirectory(prefix="llmpas-fd-") as tmp:
            workdir = Path(tmp)
            started = time.monotonic()
            translated = _translate(workdir, domain_pddl, problem_pddl, budget)
            translate_time = time.monotonic() - started
            if isinstance(translated, _Failure):
                return _failure(translated.status, translated.message, translate_time)
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                message = f"translation took {translate_time:.2f} s of max_time {budget} s"
                return _failure(ClassicalStatus.TIMEOUT, message, translate_time)
            return _search(binary, self.config, translated, workdir, remaining, translate_time)


# --- translation -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Failure:
    status: ClassicalStatus
    message: str


def _translate(workdir: Path, domain_pddl: str, problem_pddl: str, budget: float) -> str | _Failure:
    """SAS+ text of the task, or why there is none. Translator output goes to the log."""
    domain_file, problem_file = workdir / "domain.pddl", workdir / "problem.pddl"
    domain_file.write_text(domain_pddl)
    problem_file.write_text(problem_pddl)
    output = io.StringIO()
    try:
        with contextlib.redirect_stdout(output), contextlib.redirect_stderr(output):
            sas_text = _run_translator(domain_file, problem_file, budget)
    except MemoryError:
        return _Failure(ClassicalStatus.OUT_OF_MEMORY, "translator ran out of memory")
    except SystemExit as exc:
        return _translator_exit(exc, workdir)
    except Exception as exc:  # the translator reports bad input with assorted exceptions
        text = _one_line(str(exc), workdir) or type(exc).__name__
        return _Failure(ClassicalStatus.ERROR, f"translation failed: {text}")
    finally:
        logger.debug("translator output:\n%s", output.getvalue())
    lines = output.getvalue().splitlines()
    unsolvable = [line for line in lines if "Generating unsolvable task" in line]
    if unsolvable:
        return _Failure(ClassicalStatus.UNSOLVABLE, f"translator: {unsolvable[0].strip()}")
    return sas_text


def _run_translator(domain_file: Path, problem_file: Path, budget: float) -> str:
    from fast_downward.translate import main as translate_main
    from fast_downward.translate import normalize, options, pddl_parser

    previous = options.options
    arguments = [str(domain_file), str(problem_file)]
    arguments += ["--invariant-generation-max-time", str(max(1, math.ceil(budget)))]
    options.set_options(arguments)
    try:
        task = pddl_parser.open(
            domain_filename=str(domain_file), problem_filename=str(problem_file)
        )
        normalize.normalize(task)
        sas_task = translate_main.pddl_to_sas(task)
        sas = io.StringIO()
        sas_task.output(sas)
        return sas.getvalue()
    finally:
        options.options = previous


def _translator_exit(exc: SystemExit, workdir: Path) -> _Failure:
    """Map a translator ``sys.exit`` (a message or a driver exit code) to a failure."""
    code = exc.code
    if isinstance(code, int) and not isinstance(code, bool):
        status = _EXIT_STATUS.get(code, ClassicalStatus.ERROR)
        if status is ClassicalStatus.SOLVED:  # exit without a task is never a plan
            status = ClassicalStatus.ERROR
        return _Failure(status, f"translator exited with code {code}")
    return _Failure(ClassicalStatus.ERROR, f"translation failed: {_one_line(str(code), workdir)}")


def _one_line(text: str, workdir: Path) -> str:
    text = text.replace(f"{workdir}{os.sep}", "")
    return " ".join(line.strip() for line in text.splitlines() if line.strip())


# --- search ------------------------------------------------------------------------------------

#: Fast Downward exit codes (driver/returncodes.py, FD 26.6) -> status. Codes 1-3 (plan found
#: and a limit hit) only occur in portfolios; a plan file decides. 10, 20, 21, 30, 31 come from the
#: translator driver, which is not used here, but a SystemExit may carry them.
_EXIT_STATUS: dict[int, ClassicalStatus] = {
    0: ClassicalStatus.SOLVED,
    1: ClassicalStatus.SOLVED,
    2: ClassicalStatus.SOLVED,
    3: ClassicalStatus.SOLVED,
    10: ClassicalStatus.UNSOLVABLE,  # TRANSLATE_UNSOLVABLE
    11: ClassicalStatus.UNSOLVABLE,  # SEARCH_UNSOLVABLE
    12: ClassicalStatus.UNSOLVABLE,  # SEARCH_UNSOLVED_INCOMPLETE (not a proof; see message)
    13: ClassicalStatus.UNSOLVABLE,  # SEARCH_UNSOLVABLE_WITHIN_BOUND
    20: ClassicalStatus.OUT_OF_MEMORY,  # TRANSLATE_OUT_OF_MEMORY
    21: ClassicalStatus.TIMEOUT,  # TRANSLATE_OUT_OF_TIME
    22: ClassicalStatus.OUT_OF_MEMORY,  # SEARCH_OUT_OF_MEMORY
    23: ClassicalStatus.TIMEOUT,  # SEARCH_OUT_OF_TIME
    24: ClassicalStatus.OUT_OF_MEMORY,  # SEARCH_OUT_OF_MEMORY_AND_TIME
}
_UNSOLVABLE_MESSAGES = {
    11: "search proved the task unsolvable (exit code 11)",
    12: "no plan: an incomplete search exhausted its space (exit code 12); may be solvable",
    13: "no plan within the search's cost bound (exit code 13)",
}
#: Signals that mean the CPU limit was enforced (SIGXCPU unhandled, or the hard limit's SIGKILL).
_TIME_SIGNALS = (signal.SIGXCPU, signal.SIGKILL)
_MEMORY_WORDS = ("failed to map segment", "cannot allocate memory", "bad_alloc")


def _limits_setter(cpu_seconds: int, memory_bytes: int) -> Callable[[], None]:
    """``preexec_fn`` for the search child: soft CPU limit (SIGXCPU -> FD exits 23), hard +1 s."""

    def apply() -> None:
        _set_limit(resource.RLIMIT_CPU, cpu_seconds, cpu_seconds + 1)
        _set_limit(resource.RLIMIT_AS, memory_bytes, memory_bytes)

    return apply


def _set_limit(which: int, soft: int, hard: int) -> None:
    _, current_hard = resource.getrlimit(which)
    if current_hard != resource.RLIM_INFINITY:
        soft, hard = min(soft, current_hard), min(hard, current_hard)
    resource.setrlimit(which, (soft, hard))


def _search(
    binary: Path,
    config: DownwardConfig,
    sas_text: str,
    workdir: Path,
    remaining: float,
    translate_time: float,
) -> ClassicalPlan:
    plan_file = workdir / "plan"
    command = [str(binary), "--search", config.search, "--internal-plan-file", str(plan_file)]
    preexec = _limits_setter(max(1, math.ceil(remaining)), config.memory_mb * 1024 * 1024)
    started = time.monotonic()
    try:
        result = subprocess.run(
            command,
            input=sas_text,
            capture_output=True,
            text=True,
            cwd=workdir,
            preexec_fn=preexec,
            timeout=remaining + min(_KILL_GRACE_S, 0.1 * remaining),
            check=False,
        )
    except subprocess.TimeoutExpired:
        search_time = time.monotonic() - started
        message = f"search exceeded {remaining:.2f} s (killed)"
        return _failure(ClassicalStatus.TIMEOUT, message, translate_time, search_time)
    search_time = time.monotonic() - started
    logger.debug("search exit code %d, output tail:\n%s", result.returncode, result.stdout[-2000:])
    status, message = _classify(result, config, remaining)
    if status is not ClassicalStatus.SOLVED:
        return _failure(status, message, translate_time, search_time)
    return _read_plan(workdir, translate_time, search_time)


def _classify(
    result: subprocess.CompletedProcess[str], config: DownwardConfig, remaining: float
) -> tuple[ClassicalStatus, str]:
    code = result.returncode
    if code < 0 and -code in _TIME_SIGNALS:
        return ClassicalStatus.TIMEOUT, f"search exceeded {remaining:.2f} s ({_exit_text(code)})"
    status = _EXIT_STATUS.get(code)
    if status is None and any(word in result.stderr.lower() for word in _MEMORY_WORDS):
        status = ClassicalStatus.OUT_OF_MEMORY  # e.g. the loader cannot map libstdc++ (127)
    if status is ClassicalStatus.OUT_OF_MEMORY:
        return status, f"search hit memory limit {config.memory_mb} MB (exit code {code})"
    if status is ClassicalStatus.TIMEOUT:
        return status, f"search exceeded {remaining:.2f} s (exit code {code})"
    if status is ClassicalStatus.UNSOLVABLE:
        return status, _UNSOLVABLE_MESSAGES.get(code, f"search found no plan (exit code {code})")
    if status is ClassicalStatus.SOLVED:
        return status, ""
    return ClassicalStatus.ERROR, f"search failed ({_exit_text(code)}): {_last_line(result)}"


def _exit_text(code: int) -> str:
    if code >= 0:
        return f"exit code {code}"
    try:
        return f"signal {signal.Signals(-code).name}"
    except ValueError:
        return f"signal {-code}"


_NOISE = (
    "Traceback:",
    "Usage error occurred.",
    "Terminating.",
    "Tried to use unsupported feature.",
    "Valid keyword arguments",
    "Peak memory:",
    "Search stopped.",
    "[t=",
)


def _last_line(result: subprocess.CompletedProcess[str]) -> str:
    """Cause of a failed search: the last unindented, non-trailer line of stderr (else stdout)."""
    for stream in (result.stderr, result.stdout):
        lines = [line.strip() for line in stream.splitlines() if line[:1].strip()]
        lines = [line for line in lines if not line.startswith(_NOISE)]
        if lines:
            return lines[-1]
    return "no output"


# --- plan file ---------------------------------------------------------------------------------

_COST_LINE = re.compile(r";\s*cost\s*=\s*(\d+(?:\.\d*)?)")


def _read_plan(workdir: Path, translate_time: float, search_time: float) -> ClassicalPlan:
    plan_file = _plan_file(workdir)
    if plan_file is None:
        message = "search reported success but wrote no plan file"
        return _failure(ClassicalStatus.ERROR, message, translate_time, search_time)
    actions, cost = parse_plan(plan_file.read_text())
    return ClassicalPlan(ClassicalStatus.SOLVED, actions, cost, translate_time, search_time)


def _plan_file(workdir: Path) -> Path | None:
    """``plan``, or the last ``plan.N`` written by an anytime (iterated) search."""
    single = workdir / "plan"
    if single.is_file():
        return single
    numbered = [p for p in workdir.glob("plan.*") if p.suffix[1:].isdigit()]
    return max(numbered, key=lambda p: int(p.suffix[1:]), default=None)


def parse_plan(text: str) -> tuple[tuple[Action, ...], float]:
    """Actions and cost of a Fast Downward plan file (unit cost if no cost comment)."""
    actions: list[Action] = []
    cost: float | None = None
    for raw in text.splitlines():
        line = raw.strip()
        if line.startswith(";"):
            match = _COST_LINE.match(line)
            cost = float(match.group(1)) if match else cost
        elif line.startswith("(") and line.endswith(")") and line[1:-1].strip():
            name, *arguments = line[1:-1].lower().split()
            actions.append((name, tuple(arguments)))
    return tuple(actions), float(len(actions)) if cost is None else cost
