"""The error classes every entry point maps to an exit status, and how an error is shown.

Each error renders as one line naming where the problem is: a file and place
(``domain.pddl:12:5: ...``), an option (``--max-time: ...``) or a server. The command line
(:func:`llmpas.cli.main`) prints it after ``error:`` and exits with the class's
:class:`ExitCode`; anything else that escapes is an internal error (a bug), shown the same way.
"""

from __future__ import annotations

import enum

from llmpas.safetext import printable


class ExitCode(enum.IntEnum):
    """Exit statuses of ``llmpas`` (documented in ``llmpas --help`` and the README)."""

    OK = 0
    FAILED = 1  # the command ran but did not succeed: no plan, task not done
    USAGE = 2  # bad command line: unknown option or name, bad option value
    INPUT = 3  # an input file is unreadable, too large or invalid (PDDL, TOML, bindings)
    PLANNER = 4  # the planner itself failed (crashed, translator error)
    LLM = 5  # the LLM backend failed (server, model, cassette)
    IO = 6  # an output cannot be written (--out, disk full)
    INTERNAL = 8  # a bug in llmpas: run with -v for the traceback
    INTERRUPTED = 130  # Ctrl-C


EXIT_CODES_HELP = (
    "exit status: 0 done, 1 ran but failed (no plan, task not done), 2 usage (options, names), "
    "3 bad input file, 4 planner failure, 5 LLM failure, 6 output cannot be written, "
    "8 internal error, 130 interrupted; errors are one line on stderr (-v adds the traceback)"
)


class LlmpasError(Exception):
    """Base class of errors with a known cause; ``code`` is the exit status of the CLI."""

    code: ExitCode = ExitCode.INTERNAL


class UsageError(LlmpasError):
    """A bad command line: an option value, an unknown name (scenario, example, model)."""

    code = ExitCode.USAGE


class InputError(LlmpasError, ValueError):
    """An input file that cannot be read or makes no valid problem: ``file[:line:col]: why``."""

    code = ExitCode.INPUT


class PlannerError(LlmpasError):
    """The planner failed on a valid problem (a crash, a translator error)."""

    code = ExitCode.PLANNER


class OutputError(LlmpasError):
    """An output place that cannot be written: ``--out DIR: why``."""

    code = ExitCode.IO


class RobotLostError(LlmpasError):
    """The robot went away mid-run (a server of it vanished: its node was killed). Not an
    anomaly to reason about: the run ends, naming the server and where it was looked for."""

    code = ExitCode.FAILED


def one_line(text: str, limit: int = 1000) -> str:
    """``text`` as one printable line: control characters (newlines, terminal escapes) and lone
    surrogates escaped (:func:`llmpas.safetext.printable`), the middle cut out when longer than
    ``limit`` characters."""
    safe = printable(text, keep_newlines=False)
    if len(safe) <= limit:
        return safe
    half = (limit - 5) // 2
    return f"{safe[:half]} ... {safe[-half:]}"


__all__ = [
    "EXIT_CODES_HELP",
    "ExitCode",
    "InputError",
    "LlmpasError",
    "OutputError",
    "PlannerError",
    "RobotLostError",
    "UsageError",
    "one_line",
]
