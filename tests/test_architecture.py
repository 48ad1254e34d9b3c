"""The architecture picture (docs/architecture.dot, drawn as docs/img/architecture.svg) is the
code's: every import from one part of llmpas into another is an arrow of the picture, and every
arrow of the picture is an import of the code (read by grimp, the import graph import-linter
uses). A part is a package of llmpas (``planning``, ``worlds``, ...), the command line
(``cli.py`` and ``commands/``), or ``common`` (the top-level modules every layer may use)."""

from __future__ import annotations

import re
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[1]
DOT = ROOT / "docs" / "architecture.dot"
SVG = ROOT / "docs" / "img" / "architecture.svg"
SRC = ROOT / "src" / "llmpas"
CLI = {"cli", "commands", "__main__"}


def part(module: str) -> str:
    """The part of llmpas a module belongs to."""
    name = module.split(".")[1] if module.count(".") >= 1 else "common"
    if name in CLI:
        return "cli"
    return name if (SRC / name).is_dir() else "common"


def code_arrows() -> set[tuple[str, str]]:
    graph = grimp.build_graph("llmpas", cache_dir=None)
    arrows = set()
    for module in graph.modules:
        for imported in graph.find_modules_directly_imported_by(module):
            a, b = part(module), part(imported)
            if a != b:
                arrows.add((a, b))
    return arrows


def drawn_arrows() -> set[tuple[str, str]]:
    text = DOT.read_text(encoding="utf-8")
    return set(re.findall(r'"?(\w+)"?\s*->\s*"?(\w+)"?', text))


def test_every_import_between_parts_is_drawn_and_every_arrow_is_an_import() -> None:
    code, drawn = code_arrows(), drawn_arrows()
    assert code - drawn == set(), f"imports the picture lacks: {sorted(code - drawn)}"
    assert drawn - code == set(), f"arrows the code lacks: {sorted(drawn - code)}"


def test_the_picture_has_no_arrow_back_up_the_layers() -> None:
    """The picture (and so the code) is a one-way graph: no part reaches itself again."""
    arrows = drawn_arrows()
    nodes = {a for a, _ in arrows} | {b for _, b in arrows}
    seen: dict[str, int] = {}

    def visit(n: str) -> None:
        seen[n] = 1
        for a, b in arrows:
            if a == n:
                assert seen.get(b) != 1, f"a circle through {n} -> {b}"
                if b not in seen:
                    visit(b)
        seen[n] = 2

    for n in sorted(nodes):
        if n not in seen:
            visit(n)


def test_the_drawn_picture_shows_the_dot_file() -> None:
    """docs/img/architecture.svg was drawn from docs/architecture.dot as it is: the same arrows
    (graphviz titles each edge ``a->b``)."""
    svg = SVG.read_text(encoding="utf-8").replace("&#45;", "-").replace("&gt;", ">")
    shown = set(re.findall(r"<title>(\w+)->(\w+)</title>", svg))
    assert shown == drawn_arrows()
