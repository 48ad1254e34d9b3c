"""``llmpas bench NAME``: the benchmarks (:mod:`llmpas.experiments`), the only command that imports
them."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence

from rich.console import Console

from llmpas.commands.cmd_common import CliError, Handler, one_line_errors
from llmpas.errors import ExitCode

Runner = Callable[[Sequence[str]], int]  # llmpas.cli.main: ``bench all`` runs each step with it


def add_bench(
    sub: argparse._SubParsersAction[argparse.ArgumentParser], runner: Runner, full: bool = True
) -> None:
    """``llmpas bench NAME``: one subcommand per registered benchmark
    (:data:`llmpas.experiments.benchmarks.BENCHMARKS`), then ``bench all``, which runs them.
    ``full``: False when the command line runs another command: ``bench`` is listed, its
    subcommands (and the experiments) are not loaded."""
    p = sub.add_parser("bench", help="benchmarks and experiments")
    if not full:
        return
    from llmpas.experiments.benchmarks import benchmarks

    bsub = p.add_subparsers(dest="bench", required=True)
    for bench in benchmarks():
        b = bsub.add_parser(bench.name, help=bench.help)
        bench.add_arguments(b)
        b.set_defaults(handler=_bench_errors(bench.command))
    _add_bench_all(bsub, runner)


def _add_bench_all(
    bsub: argparse._SubParsersAction[argparse.ArgumentParser], runner: Runner
) -> None:
    """``llmpas bench all``: every experiment with one backend (each step is one command)."""
    from llmpas.experiments import everything

    p = bsub.add_parser("all", help="every experiment with one LLM backend, one after another")
    everything.add_arguments(p)
    p.set_defaults(handler=_bench_errors(lambda a, c: everything.command(a, c, runner)))


def _bench_errors(command: Handler) -> Handler:
    """:func:`~llmpas.commands.cmd_common.one_line_errors`, and a sweep that could not finish
    (what finished is cached) as a one-line failure."""

    def handler(args: argparse.Namespace, console: Console) -> int:
        from llmpas.experiments.jobs import JobsLost

        try:
            return command(args, console)
        except JobsLost as e:
            raise CliError(str(e), ExitCode.FAILED) from None

    return one_line_errors(handler)


__all__ = ["Runner", "add_bench"]
