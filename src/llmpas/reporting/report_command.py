"""``llmpas report RUN_DIR``: (re)build a run folder's ``index.html`` from its files, and
optionally photograph it in headless Chromium (``--screenshot PNG``); and the hook the ``run``
and ``execute`` commands call after writing a folder."""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rich.console import Console

from llmpas.reporting.page import build_report
from llmpas.reporting.run_folder import ReportError

_USERINFO = re.compile(r"//[^/@\s]*@")


def public_llm(spec: str) -> str:
    """An ``--llm`` spec fit to be written down: credentials in a URL are left out."""
    return _USERINFO.sub("//", spec)


def after_run(args: argparse.Namespace, echo: Callable[[str], None], **about: Any) -> None:
    """Write ``index.html`` into ``args.out`` after a ``run`` or ``execute`` command wrote its
    files (with what the command knew: scenario, world, LLM, method, the command line). A page
    that cannot be built is reported in one line; the run's own outcome stands."""
    if not getattr(args, "out", None):
        return
    llm = None if getattr(args, "no_llm", False) else getattr(args, "llm", None)
    line = [f"llmpas {args.command} {args.scenario}"]
    if llm:
        llm = public_llm(str(llm))
        about |= {"llm": llm, "method": args.method, "decoding": args.decoding}
        line.append(f"--llm {llm} --method {args.method} --decoding {args.decoding}")
        extra = {
            "--protocol": getattr(args, "protocol", "assisted"),
            "--assists": getattr(args, "assists", None),
            "--votes": getattr(args, "votes", 1),
        }
        defaults = {"--protocol": "assisted", "--assists": None, "--votes": 1}
        line += [f"{k} {v}" for k, v in extra.items() if v != defaults[k]]
        if getattr(args, "with_replan", False):
            line.append("--with-replan")
    line.append(f"--out {args.out}")
    about = {"scenario": args.scenario, "world": "household", **about, "command": " ".join(line)}
    try:
        built = build_report(Path(args.out), about)
    except (ReportError, OSError) as e:
        echo(f"no index.html: {e}")
        return
    echo(f"web report: {built.path}")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", help="a folder written by 'llmpas run/execute ... --out'")
    p.add_argument("--screenshot", help="also write a full-page PNG of it (headless Chromium)")
    p.add_argument("--width", type=int, default=1280, help="browser width for the screenshot")
    p.add_argument(
        "--height", type=int, help="only the top HEIGHT pixels (default: the whole page)"
    )


def command(args: argparse.Namespace, console: Console) -> int:
    """``llmpas report``; a folder that cannot be reported is a ValueError of one line."""
    from llmpas.reporting import browser

    if not 320 <= args.width <= 4000:
        raise ValueError(f"--width {args.width}: give 320 to 4000 pixels")
    if args.height is not None and not 100 <= args.height <= 30000:
        raise ValueError(f"--height {args.height}: give 100 to 30000 pixels")
    try:
        built = build_report(Path(args.run_dir))
    except (ReportError, OSError) as e:
        raise ValueError(str(e)) from None
    console.print(f"wrote {built.path} ({built.bytes / 1e6:.2f} MB in {built.seconds:.2f} s)")
    if args.screenshot:
        try:
            shot = browser.screenshot(built.path, args.screenshot, args.width, args.height)
        except browser.BrowserMissing as e:
            raise ValueError(str(e)) from None
        except Exception as e:  # the browser failed to start or to draw: one line, no traceback
            first = (str(e).strip().splitlines() or [""])[0]
            why = f"{type(e).__name__}: {first}"
            raise ValueError(f"--screenshot: Chromium failed: {why}") from None
        console.print(f"wrote {shot}")
    return 0


__all__ = ["add_arguments", "after_run", "command", "public_llm"]
