"""Compare two folders written by scripts/bench_smallest.sh (before and after a change).

Per benchmark: its exit status, and each table (``*.md``), CSV and JSON it wrote (its cache and
kept runs left out), compared with every number that is not a count masked (times, rates, ratios
and paths differ from run to run); then its console output the same way, and each ``--help`` with
its option lines sorted (the order of the options may change, not what they say). Logs one line
per file and exits 1 when any differs. Usage: python scripts/bench_compare.py BEFORE AFTER
"""

from __future__ import annotations

import difflib
import logging
import re
import sys
from pathlib import Path

log = logging.getLogger("bench_compare")

FLOAT = re.compile(r"-?\d+\.\d+(?:e[-+]?\d+)?")  # a measured value (a count is an integer)
TIME = re.compile(r"\b\d+:\d\d:\d\d\b|\b\d+(?:\.\d+)?\s*(?:s|ms|MB|KB|x)\b")
PATHS = re.compile(r"/(?:work|tmp)/[^\s,'\")|]+")
STAMP = re.compile(r"\d{4}-\d\d-\d\d[T ]\d\d:\d\d:\d\d\S*")
SKIP = {"cache", "runs", "record", "suite"}  # caches, kept runs, inputs
OUTPUTS = (".md", ".csv", ".json")


def masked(text: str, root: Path) -> list[str]:
    text = text.replace(str(root), "OUT")
    for pattern, repl in ((STAMP, "STAMP"), (PATHS, "PATH"), (TIME, "TIME"), (FLOAT, "X")):
        text = pattern.sub(repl, text)
    lines = [re.sub(r" +", " ", line).rstrip() for line in text.splitlines()]
    # the progress bars' lines hold times and counts of cached jobs: compare what they count
    return [line for line in lines if "━" not in line and line.strip()]


def outputs(folder: Path) -> dict[str, Path]:
    return {
        str(p.relative_to(folder)): p
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.suffix in OUTPUTS and not SKIP & set(p.relative_to(folder).parts)
    }


def help_lines(text: str) -> list[str]:
    """A ``--help``'s lines sorted, its usage as the sorted options it lists (the harness adds
    the shared options after the benchmark's own: their order may change, not what they say)."""
    usage, _, rest = text.partition("\n\n")
    options = sorted(re.findall(r"\[[^\[\]]*(?:\[[^\]]*\][^\[\]]*)*\]|\S+", usage))
    return ["usage: " + " ".join(options), *sorted(rest.splitlines())]


def same(name: str, a: list[str], b: list[str]) -> bool:
    if a == b:
        log.info("same: %s", name)
        return True
    diff = list(difflib.unified_diff(a, b, "before", "after", lineterm="", n=0))
    log.warning("DIFFERENT: %s\n%s", name, "\n".join(diff[:40]))
    return False


def main(before: Path, after: Path) -> int:
    ok = True
    for rc in sorted(before.glob("*.rc")):
        name = rc.stem
        other = after / rc.name
        if not other.exists():
            log.warning("not run after: %s", name)
            ok = False
            continue
        ok &= same(f"{name}: exit status", [rc.read_text()], [other.read_text()])
        mine, theirs = outputs(before / name), outputs(after / name)
        ok &= same(f"{name}: files written", sorted(mine), sorted(theirs))
        for rel in sorted(set(mine) & set(theirs)):
            ok &= same(
                f"{name}/{rel}",
                masked(mine[rel].read_text(), before),
                masked(theirs[rel].read_text(), after),
            )
        ok &= same(
            f"{name}: console",
            masked((before / f"{name}.log").read_text(), before),
            masked((after / f"{name}.log").read_text(), after),
        )
    for help_file in sorted((before / "help").glob("*.txt")):
        other = after / "help" / help_file.name
        if other.exists():
            a, b = (help_lines(f.read_text()) for f in (help_file, other))
            ok &= same(f"--help of {help_file.stem} (lines and options sorted)", a, b)
    return 0 if ok else 1


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
