"""A small typed interface to a classical planner, implemented with Fast Downward.

Translation (PDDL -> SAS+) runs ``fast_downward.translate`` in a forked child process; search
runs the compiled ``downward`` binary shipped by ``up-fast-downward`` as a subprocess with the SAS+
file on stdin. A problem comes as PDDL text or as a :class:`ClassicalTask` (data): the child builds
the translator's own problem objects from the data, the task its parser would build from
``ClassicalTask.text``, without rendering and re-parsing hundreds of KB of text. The child runs with
the garbage collector off (the translator makes almost no reference cycles; collections cost 40 %
of its CPU on a 30,000-operator task) and ignores the objects it inherited.

Both run under a CPU-time and address-space limit plus a wall-clock deadline (the
call's ``max_time`` covers both), so a grounding blow-up ends as a typed result.

Outcomes of a task (solved, unsolvable, limits hit, bad PDDL, a crashed or killed process) are
returned as a :class:`ClassicalPlan` with a :class:`ClassicalStatus`; an installation problem (no
search binary) raises :class:`PlannerNotFound`. POSIX only (``os.fork``).

The answer depends on the task only, unless a limit fires (then ``timeout`` or
``out_of_memory``): Fast Downward 26.6's search engines have no expansion or state limit (only a
cost ``bound`` and ``max_time``), so a search runs until it finds a plan or exhausts its finite
state space; an engine's own ``max_time`` is refused, since its expiry looks like an exhausted
space (exit code 12); the translator's invariant synthesis is bounded by its candidate count.
"""

from __future__ import annotations

import contextlib
import enum
import functools
import gc
import importlib.util
import json
import logging
import math
import os
import re
import resource
import select
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from fast_downward.translate import pddl

    from llmpas.planning.config import PlannerConfig

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
_ENGINE_TIME = re.compile(r"\bmax_time\s*=")

#: Wall-clock slack (at most 10 % of the remaining time) before the search process is killed.
_KILL_GRACE_S = 0.25
_PIP_HINT = "pip install up-fast-downward==1.0.0"


class ClassicalStatus(enum.Enum):
    """Outcome of one planner call."""

    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"
    TIMEOUT = "timeout"
    OUT_OF_MEMORY = "out_of_memory"
    CRASHED = "crashed"  # the translator or search process died (a signal, no result)
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
    memory_mb: int = 4096  # address-space limit of the search (and of what translation adds)

    def __post_init__(self) -> None:
        _check_max_time(self.max_time)
        if self.memory_mb <= 0:
            raise ValueError(f"memory_mb must be positive, got {self.memory_mb}")
        check_axioms_option(self.search)
        if _ENGINE_TIME.search(self.search):
            raise ValueError(
                f"search {self.search!r} sets a max_time option: an engine's expiry looks like an "
                "exhausted search (unsolvable); limit time with DownwardConfig.max_time instead"
            )


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


Fact = tuple[str, tuple[str, ...]]
Value = tuple[str, tuple[str, ...], int]

#: A name the translator's tokenizer keeps as one word (printable ASCII but for ``( ) ; ?``).
_WORD = re.compile(r"[!-'*-:<->@-~]+")


@dataclass(frozen=True)
class ClassicalTask:
    """A classical problem as data: what a PDDL problem file for the domain says.

    ``objects`` are the problem's own (not the domain's constants) with their types, in file
    order; ``init`` the true atoms; ``values`` the ``(= (function args...) value)`` assignments
    (integers >= 0, as Fast Downward wants); ``goal`` the goal condition as PDDL text; ``metric``
    whether the plan minimises ``(total-cost)``. :attr:`text` is the same problem as a PDDL file.
    """

    name: str
    domain_name: str
    objects: tuple[tuple[str, str], ...]
    init: tuple[Fact, ...]
    values: tuple[Value, ...]
    goal: str
    metric: bool = True

    def __post_init__(self) -> None:
        # names and facts are the translator's to judge (as in a file): see _translator_task
        if not all(isinstance(x, tuple) for x in (self.objects, self.init, self.values)):
            raise TypeError("objects, init and values of a ClassicalTask must be tuples")

    @property
    def problem_text(self) -> str:
        """The same as :attr:`text`."""
        return self.text

    @functools.cached_property
    def text(self) -> str:
        """The task as a PDDL problem file."""
        typed = any(t != "object" for _, t in self.objects)
        objects = " ".join(f"{o} - {t}" if typed else o for o, t in self.objects)
        init = ["(" + " ".join((p, *args)) + ")" for p, args in self.init]
        init += [f"(= ({' '.join((f, *args))}) {v})" for f, args, v in self.values]
        metric = "\n  (:metric minimize (total-cost))" if self.metric else ""
        return (
            f"(define (problem {self.name})\n  (:domain {self.domain_name})\n"
            f"  (:objects {objects})\n  (:init\n    " + "\n    ".join(init) + ")\n"
            f"  (:goal {self.goal}){metric})\n"
        )


@runtime_checkable
class TaskPlanner(Protocol):
    """A classical planner that also takes the problem as data (:class:`ClassicalTask`)."""

    def solve_task(
        self, domain_pddl: str, task: ClassicalTask, *, max_time: float | None = None
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
        return self._solve(domain_pddl, problem_pddl, max_time)

    def solve_task(
        self, domain_pddl: str, task: ClassicalTask, *, max_time: float | None = None
    ) -> ClassicalPlan:
        """Plan for the domain text and the problem as data; the same plan as
        ``solve(domain_pddl, task.text)``, without rendering and re-parsing the problem."""
        return self._solve(domain_pddl, task, max_time)

    def sas(
        self, domain_pddl: str, problem: str | ClassicalTask, *, max_time: float | None = None
    ) -> str:
        """The SAS+ task the search would get (for tests and debugging); ``ValueError`` with the
        translator's one-line message if there is none."""
        budget = self.config.max_time if max_time is None else max_time
        _check_max_time(budget)
        with tempfile.TemporaryDirectory(prefix="llmpas-fd-") as tmp:
            translated = _translate(Path(tmp), domain_pddl, problem, budget, self.config.memory_mb)
            if isinstance(translated, _Failure):
                raise ValueError(f"{translated.status.value}: {translated.message}")
            return translated.read_text()

    def _solve(
        self, domain_pddl: str, problem: str | ClassicalTask, max_time: float | None
    ) -> ClassicalPlan:
        binary = self.binary
        budget = self.config.max_time if max_time is None else max_time
        _check_max_time(budget)
        deadline = time.monotonic() + budget
        with tempfile.TemporaryDirectory(prefix="llmpas-fd-") as tmp:
            workdir = Path(tmp)
            started = time.monotonic()
            translated = _translate(workdir, domain_pddl, problem, budget, self.config.memory_mb)
            translate_time = time.monotonic() - started
            if isinstance(translated, _Failure):
                return _failure(translated.status, translated.message, translate_time)
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                message = f"translation took {translate_time:.2f} s of max_time {budget} s"
                return _failure(ClassicalStatus.TIMEOUT, message, translate_time)
            return _search(binary, self.config, translated, workdir, remaining, translate_time)


def fast_downward(search: str, config: PlannerConfig) -> FastDownward:
    """The registered classical planner ``fast-downward``
    (:data:`~llmpas.planning.planner_registry.CLASSICAL_PLANNERS`): Fast Downward running ``search``
    within the config's per-search time and memory."""
    return FastDownward(
        DownwardConfig(search=search, max_time=config.search_time, memory_mb=config.memory_mb)
    )


# --- translation -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Failure:
    status: ClassicalStatus
    message: str


#: What a translator child writes to its pipe when it ran out of memory (no allocation needed).
_CHILD_OOM = b'{"status": "out_of_memory", "message": "translator ran out of memory"}'


def _translate(
    workdir: Path, domain_pddl: str, problem: str | ClassicalTask, budget: float, memory_mb: int
) -> Path | _Failure:
    """The SAS+ file of the task, or why there is none.

    The translator runs in a forked child (cheap: the translator is already imported) with an
    address-space limit of ``memory_mb`` beyond what the parent had mapped, a CPU limit, and a
    wall-clock deadline after which the parent kills it; its output goes to the debug log. A
    :class:`ClassicalTask` reaches the child as the parent's objects (copy-on-write)."""
    domain_file, problem_file = workdir / "domain.pddl", workdir / "problem.pddl"
    domain_file.write_text(domain_pddl)
    if isinstance(problem, str):
        problem_file.write_text(problem)
    source: Path | ClassicalTask = problem_file if isinstance(problem, str) else problem
    sas_file, log_file = workdir / "output.sas", workdir / "translate.log"
    _import_translator()
    deadline = time.monotonic() + budget
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - runs in the child, which never returns
        os.close(read_fd)
        _translator_child(write_fd, domain_file, source, sas_file, log_file, budget, memory_mb)
    os.close(write_fd)
    try:
        report, killed = _await_child(pid, read_fd, deadline)
    finally:
        os.close(read_fd)
    wait_status = os.waitpid(pid, 0)[1]
    if log_file.is_file():
        logger.debug("translator output:\n%s", log_file.read_text(errors="replace")[-4000:])
    if killed:
        return _Failure(ClassicalStatus.TIMEOUT, f"translation exceeded {budget:.2f} s (killed)")
    return _child_outcome(report, wait_status, sas_file, workdir, budget)


def _import_translator() -> None:
    """Import the translator in the parent, so that forked children share it."""
    from fast_downward.translate import main as _main  # noqa: F401


def _await_child(pid: int, read_fd: int, deadline: float) -> tuple[bytes, bool]:
    """Everything the child wrote to the pipe (until it closed it or died), and whether it was
    killed at the deadline."""
    chunks: list[bytes] = []
    while True:
        remaining = deadline - time.monotonic()
        ready, _, _ = select.select([read_fd], [], [], max(0.0, remaining))
        if not ready:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
            return b"", True
        chunk = os.read(read_fd, 65536)
        if not chunk:
            return b"".join(chunks), False
        chunks.append(chunk)


def _child_outcome(
    report: bytes, wait_status: int, sas_file: Path, workdir: Path, budget: float
) -> Path | _Failure:
    """Interpret the child's report and exit status."""
    if os.WIFSIGNALED(wait_status):
        sig = os.WTERMSIG(wait_status)
        if sig == signal.SIGXCPU:  # the CPU limit (our own kill at the deadline is seen above)
            return _Failure(ClassicalStatus.TIMEOUT, f"translation exceeded {budget:.2f} s CPU")
        return _Failure(ClassicalStatus.CRASHED, f"translator crashed ({_signal_name(sig)})")
    try:
        parsed = json.loads(report.decode("utf-8", "replace"))
        status, message = ClassicalStatus(parsed["status"]), str(parsed["message"])
    except (ValueError, KeyError, TypeError):
        code = os.waitstatus_to_exitcode(wait_status)
        return _Failure(ClassicalStatus.CRASHED, f"translator died without a result (exit {code})")
    if status is ClassicalStatus.SOLVED:
        return sas_file
    return _Failure(status, _one_line(message, workdir))


def _translator_child(
    write_fd: int,
    domain_file: Path,
    problem: Path | ClassicalTask,
    sas_file: Path,
    log_file: Path,
    budget: float,
    memory_mb: int,
) -> None:  # pragma: no cover - runs in the forked child
    """Translate under limits, write the SAS+ file and a one-line JSON report; never returns."""
    code = 0
    try:
        gc.freeze()  # never scan (and so copy) the objects inherited from the parent
        gc.disable()  # the translator makes almost no cycles; collections cost 40 % of its CPU
        _set_limit(resource.RLIMIT_CPU, math.ceil(budget) + 1, math.ceil(budget) + 2)
        _set_limit(resource.RLIMIT_AS, *([_mapped_bytes() + memory_mb * 1024 * 1024] * 2))
        with open(log_file, "w") as log:
            os.dup2(log.fileno(), 1)
            os.dup2(log.fileno(), 2)
            sys.stdout = sys.stderr = log
            report = _translate_in_child(domain_file, problem, sas_file, budget)
            log.flush()
        os.write(write_fd, json.dumps(report).encode())
    except MemoryError:
        os.write(write_fd, _CHILD_OOM)
    except BaseException:  # a child must end with os._exit, whatever happened
        code = 1
    finally:
        os._exit(code)


def _translate_in_child(
    domain_file: Path, problem: Path | ClassicalTask, sas_file: Path, budget: float
) -> dict[str, str]:
    status, message = ClassicalStatus.SOLVED, ""
    try:
        _run_translator(domain_file, problem, sas_file, budget)
    except MemoryError:
        raise
    except SystemExit as exc:
        failure = _translator_exit(exc)
        status, message = failure.status, failure.message
    except RecursionError:
        status, message = ClassicalStatus.ERROR, "translation failed: input nested too deeply"
    except Exception as exc:  # the translator reports bad input with assorted exceptions
        text = " ".join(str(exc).split()) or type(exc).__name__
        status, message = ClassicalStatus.ERROR, f"translation failed: {text}"
    if status is ClassicalStatus.SOLVED:
        sys.stdout.flush()
        unsolvable = _unsolvable_line(Path(sys.stdout.name))
        if unsolvable:
            status, message = ClassicalStatus.UNSOLVABLE, f"translator: {unsolvable}"
    return {"status": status.value, "message": message}


def _unsolvable_line(log_file: Path) -> str:
    for line in log_file.read_text(errors="replace").splitlines():
        if "Generating unsolvable task" in line:
            return line.strip()
    return ""


def _mapped_bytes() -> int:
    """Virtual memory this process has mapped (0 where /proc is not available)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 0
    return pages * resource.getpagesize()


def _run_translator(
    domain_file: Path, problem: Path | ClassicalTask, sas_file: Path, budget: float
) -> None:
    from fast_downward.translate import main as translate_main
    from fast_downward.translate import normalize, options, pddl_parser

    problem_file = problem if isinstance(problem, Path) else domain_file.with_name("problem.pddl")
    arguments = [str(domain_file), str(problem_file), *_invariant_arguments(budget)]
    options.set_options(arguments)  # the child's own copy of the translator's global options
    task = None if isinstance(problem, Path) else _translator_task(domain_file, problem)
    if task is None:  # text, or data only the parser can judge: it says what is wrong
        if not isinstance(problem, Path):
            problem_file.write_text(problem.text)
        task = pddl_parser.open(
            domain_filename=str(domain_file), problem_filename=str(problem_file)
        )
    normalize.normalize(task)
    sas_task = translate_main.pddl_to_sas(task)
    with open(sas_file, "w") as out:
        sas_task.output(out)


def _translator_task(domain_file: Path, problem: ClassicalTask) -> pddl.Task | None:
    """The translator's task for the domain file and ``problem``: what its parser builds from the
    domain file and ``problem.text``, in the same order (the domain is parsed from its file: 1 ms
    for the tamp2d domain). None where the parser would reject or re-read the data (a name it
    splits or does not know, an arity, duplicates, conflicting values): parsing the text then
    reports the error in the translator's own words."""
    from fast_downward.translate import pddl
    from fast_downward.translate.pddl_parser import lisp_parser, pddl_file
    from fast_downward.translate.pddl_parser import parsing_functions as parsing

    words = {w for pair in problem.objects for w in pair} | {p for p, _ in problem.init}
    words |= {f for f, _, _ in problem.values} | {problem.name, problem.domain_name}
    if not all(_plain_word(w) for w in words) or ";" in problem.goal:
        return None
    try:
        context = parsing.Context()
        domain = pddl_file.parse_pddl_file("domain", str(domain_file))
        (name, requirements, types, type_dict, constants, predicates, predicate_dict, functions,
         actions, axioms) = parsing.parse_domain_pddl(context, domain)  # fmt: skip
        objects = [pddl.TypedObject(o.lower(), t.lower()) for o, t in problem.objects]
        names = [o.name for o in constants + objects]
        if name != problem.domain_name.lower() or len(set(names)) != len(names):
            return None
        terms = {c.name: c.name for c in constants} | {o: o.lower() for o, _ in problem.objects}
        init: list[pddl.Atom | pddl.Assign] = []
        assigned: dict[pddl.PrimitiveNumericExpression, int] = {}
        for function, args, value in problem.values:
            # the parser takes a value's arguments as they are (objects or not)
            if not all(a in terms or _plain_word(a) for a in args):
                return None
            lowered_args = [terms.get(a) or a.lower() for a in args]
            head = pddl.PrimitiveNumericExpression(function.lower(), lowered_args)
            if type(value) is not int or value < 0 or assigned.get(head, value) != value:
                return None
            if head not in assigned:  # a repetition of the same value is ignored, as in text
                assigned[head] = value
                init.append(pddl.Assign(head, pddl.NumericConstant(value)))
        atoms: dict[pddl.Atom, None] = {}
        for predicate, args in problem.init:
            lowered = predicate.lower()
            if lowered in ("=", "not") or len(predicate_dict[lowered].arguments) != len(args):
                return None
            atoms[pddl.Atom(lowered, [terms[a] for a in args])] = None
        goal_list = lisp_parser.parse_nested_list([problem.goal])
        goal = parsing.parse_condition(context, goal_list, type_dict, predicate_dict, set(names))
    except MemoryError:
        raise
    except (Exception, SystemExit):  # an unknown name or predicate, a bad domain or goal
        return None
    init += atoms
    init += [pddl.Atom("=", (n, n)) for n in names]
    problem_requirements = pddl.Requirements(sorted(set(requirements.requirements)))
    return pddl.Task(
        name, problem.name.lower(), problem_requirements, types, constants + objects, predicates,
        functions, init, goal, actions, axioms, problem.metric,
    )  # fmt: skip


def _plain_word(word: str) -> bool:
    """The translator's tokenizer reads ``word`` as one name (lower-cased) in any position."""
    return word != "-" and _WORD.fullmatch(word) is not None


def _invariant_arguments(budget: float) -> list[str]:
    """Invariant synthesis is bounded by its candidate count (the translator's default, 100000),
    not by time: its CPU-time cut is set past the child's CPU limit (``ceil(budget) + 1``), so
    that it never fires and the SAS+ task does not depend on the machine's speed; a translation
    that slow ends as a timeout."""
    return ["--invariant-generation-max-time", str(math.ceil(budget) + 2)]


def _translator_exit(exc: SystemExit) -> _Failure:
    """Map a translator ``sys.exit`` (a message or a driver exit code) to a failure."""
    code = exc.code
    if isinstance(code, int) and not isinstance(code, bool):
        status = _EXIT_STATUS.get(code, ClassicalStatus.ERROR)
        if status is ClassicalStatus.SOLVED:  # exit without a task is never a plan
            status = ClassicalStatus.ERROR
        return _Failure(status, f"translator exited with code {code}")
    return _Failure(ClassicalStatus.ERROR, f"translation failed: {code}")


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
    sas_file: Path,
    workdir: Path,
    remaining: float,
    translate_time: float,
) -> ClassicalPlan:
    plan_file = workdir / "plan"
    command = [str(binary), "--search", config.search, "--internal-plan-file", str(plan_file)]
    preexec = _limits_setter(max(1, math.ceil(remaining)), config.memory_mb * 1024 * 1024)
    started = time.monotonic()
    try:
        with open(sas_file) as sas:
            result = subprocess.run(
                command,
                stdin=sas,
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
    status, message = _classify(result, config, remaining, search_time)
    if status is not ClassicalStatus.SOLVED:
        return _failure(status, message, translate_time, search_time)
    return _read_plan(workdir, translate_time, search_time)


def _classify(
    result: subprocess.CompletedProcess[str],
    config: DownwardConfig,
    remaining: float,
    elapsed: float,
) -> tuple[ClassicalStatus, str]:
    code = result.returncode
    # the CPU limit sends SIGXCPU, then SIGKILL at the hard limit; a SIGKILL before the soft limit
    # could have been reached (CPU time <= wall time) came from elsewhere: a crash, not a timeout
    if code < 0 and (-code == signal.SIGXCPU or (-code == signal.SIGKILL and elapsed >= remaining)):
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
    if code < 0:
        return ClassicalStatus.CRASHED, f"search crashed ({_exit_text(code)}): {_last_line(result)}"
    return ClassicalStatus.ERROR, f"search failed ({_exit_text(code)}): {_last_line(result)}"


def _exit_text(code: int) -> str:
    return f"exit code {code}" if code >= 0 else _signal_name(-code)


def _signal_name(number: int) -> str:
    try:
        return f"signal {signal.Signals(number).name}"
    except ValueError:
        return f"signal {number}"


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
