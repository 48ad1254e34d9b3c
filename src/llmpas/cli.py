"""The ``llmpas`` command line."""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from rich.console import Console
from rich.logging import RichHandler
from rich.table import Table
from rich.text import Text

from llmpas.commands.cmd_bench import add_bench
from llmpas.commands.cmd_common import CliError, Handler
from llmpas.commands.cmd_plan import add_pddlstream, add_plan
from llmpas.commands.cmd_run import add_run
from llmpas.commands.cmd_tools import add_doctor, add_model, add_report
from llmpas.commands.cmd_world import add_execute, add_robot
from llmpas.errors import EXIT_CODES_HELP, ExitCode, LlmpasError, OutputError, UsageError, one_line
from llmpas.limits import interruptible
from llmpas.safetext import RedactingFilter, env_secrets, redact


def _cmd_examples(args: argparse.Namespace, console: Console) -> int:
    from llmpas.examples import EXAMPLES

    table = Table("name", "default size", "description")
    for ex in EXAMPLES.values():
        table.add_row(ex.name, str(ex.default_size), ex.description)
    console.print(table)
    return 0


# ------------------------------------------------------------------------------------ main


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the CLI's usage errors)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message} (see '{self.prog} --help')")


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The whole command line; with ``argv``, ``bench``'s subcommands (and the experiments) only
    when ``argv`` runs ``bench`` (``llmpas run`` loads nothing of the benchmarks)."""
    parser: argparse.ArgumentParser = _Parser(
        prog="llmpas",
        description=__doc__,
        epilog=EXIT_CODES_HELP,
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more logging; tracebacks of errors"
    )
    sub = parser.add_subparsers(dest="command", required=True)
    add_plan(sub)
    ex = sub.add_parser("examples", help="list the shipped example problems")
    ex.set_defaults(handler=_cmd_examples)
    add_execute(sub)
    add_run(sub)
    add_model(sub)
    add_doctor(sub)
    add_bench(sub, main, argv is None or _command(argv) == "bench")
    add_report(sub)
    add_pddlstream(sub)
    add_robot(sub)
    return parser


def _command(argv: Sequence[str]) -> str | None:
    """The command ``argv`` runs: its first word that is no option (the top level's options,
    ``-v`` and ``-h``, take no value)."""
    return next((a for a in argv if not a.startswith("-")), None)


# ---------------------------------------------------------------------------------- errors


OUTPUT_OPTIONS = ("out", "png", "record")  # folders a command writes: checked before it runs


def check_output_folder(path: str, option: str) -> None:
    """Refuse an output folder that cannot be written, before any work is done: it must be a
    folder (or not exist yet below a folder) where a file can be created. Nothing is left."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise OutputError(f"{option} {path}: not a folder")
    probe = target
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{option} {path}: {probe} is not a folder")
    try:
        fd, tmp = tempfile.mkstemp(dir=probe, prefix=".llmpas-write-test.")
    except OSError as e:
        raise OutputError(f"{option} {path}: cannot write in {probe}: {e.strerror or e}") from None
    os.close(fd)
    os.unlink(tmp)


def _check_outputs(args: argparse.Namespace) -> None:
    for name in OUTPUT_OPTIONS:
        value = getattr(args, name, None)
        if isinstance(value, str):
            check_output_folder(value, "--" + name)


def _classify(e: BaseException) -> tuple[ExitCode, str]:
    """The exit status and the one-line message of an error that reached :func:`main`."""
    from llmpas.reasoning.llm import LLMError

    text = str(e)
    if isinstance(e, LlmpasError):
        return e.code, text or type(e).__name__
    if isinstance(e, LLMError):
        return ExitCode.LLM, f"LLM: {text}"
    if isinstance(e, KeyboardInterrupt):
        return ExitCode.INTERRUPTED, "interrupted"
    if isinstance(e, OSError):
        where = f"{e.filename}: " if e.filename else ""
        return ExitCode.IO, f"{where}{e.strerror or text or type(e).__name__}"
    if isinstance(e, MemoryError):
        return ExitCode.INTERNAL, "out of memory (internal error; -v shows where)"
    what = f"{type(e).__name__}: {text}" if text else type(e).__name__
    return ExitCode.INTERNAL, f"internal error: {what} (run 'llmpas -v ...' for the traceback)"


def _report(e: BaseException, verbose: int) -> int:
    code, message = _classify(e)
    secrets = env_secrets()
    if verbose:
        sys.stderr.write(redact("".join(traceback.format_exception(e)), secrets))
    line = Text.assemble(("error:", "bold red"), " ", one_line(redact(message, secrets)))
    Console(stderr=True, emoji=False).print(line, soft_wrap=True, highlight=False)
    return int(code)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; every error becomes one line on stderr and a documented exit status."""
    verbose = 0
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        args = build_parser(argv).parse_args(argv)
        verbose = args.verbose
        console = Console(stderr=False)
        level = logging.WARNING - 10 * min(args.verbose, 2)
        log_handler = RichHandler(console=Console(stderr=True))
        log_handler.addFilter(RedactingFilter(env_secrets()))  # no API key in any log line
        logging.basicConfig(level=level, format="%(message)s", handlers=[log_handler])
        _check_outputs(args)
        handler: Handler = args.handler
        with interruptible():  # Ctrl-C ends the command, even started as a background job
            return handler(args, console)
    except (Exception, KeyboardInterrupt) as e:
        return _report(e, verbose)


if __name__ == "__main__":
    sys.exit(main())


__all__ = ["CliError", "build_parser", "check_output_folder", "main"]
