"""The layout says the architecture: a module's file name says its layer's job once (no two modules
in different packages share a name, but ``__init__``/``__main__``), no file of the product grows
past 800 lines, and the command line is a thin entry point (cli.py under 400 lines)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "llmpas"
SHARED_NAMES = {"__init__.py", "__main__.py"}
MAX_LINES = 800
MAX_CLI_LINES = 400


def modules() -> list[Path]:
    return sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts)


def lines(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def test_no_two_modules_share_a_file_name() -> None:
    where: dict[str, list[str]] = defaultdict(list)
    for p in modules():
        if p.name not in SHARED_NAMES:
            where[p.name].append(str(p.relative_to(SRC)))
    shared = {name: places for name, places in where.items() if len(places) > 1}
    assert not shared, f"file names used by more than one module: {shared}"


def test_no_file_of_the_product_is_over_800_lines() -> None:
    long = {str(p.relative_to(SRC)): lines(p) for p in modules() if lines(p) > MAX_LINES}
    assert not long, f"files over {MAX_LINES} lines: {long}"


def test_the_command_line_is_a_thin_entry_point() -> None:
    assert lines(SRC / "cli.py") < MAX_CLI_LINES


def test_the_checks_see_the_whole_tree() -> None:
    """The walks above read every package (a check over an empty or partial tree proves
    nothing): each layer named in the brief has modules."""
    layers = {p.relative_to(SRC).parts[0] for p in modules() if len(p.relative_to(SRC).parts) > 1}
    for layer in ("language", "planning", "execution", "reasoning", "worlds", "system",
                  "reporting", "experiments", "pddlstream"):  # fmt: skip
        assert layer in layers
    assert len(modules()) > 150
