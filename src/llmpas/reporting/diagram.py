"""CSubBT diagrams for the web report, drawn from the BehaviorTree.CPP v4 XML files on disk.

The XML is what an episode folder keeps of its subtrees (:func:`llmpas.execution.export.
to_btcpp_files`), so a report can be rebuilt from the folder alone. Each ``<BehaviorTree>``
becomes a Graphviz graph rendered to SVG by ``dot`` (time-limited); the page shows it as an
``<img>`` (an SVG loaded as an image runs no script). Without ``dot`` the tree is shown as text.
"""

from __future__ import annotations

import logging
import shutil
import subprocess
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from llmpas.reporting.html import clean

log = logging.getLogger(__name__)

MAX_XML_BYTES = 2_000_000  # a larger file is not drawn
MAX_NODES = 400  # nodes drawn per tree
DOT_TIMEOUT = 20.0  # seconds per diagram

_STYLE = {
    "RetryUntilSuccessful": 'shape=box, style="rounded,filled", fillcolor="#fde7c8", '
    'color="#c77800"',
    "Sequence": 'shape=box, style="filled", fillcolor="#e3ecf7", color="#4a6fa5"',
    "Condition": 'shape=ellipse, style="filled", fillcolor="#dff2e1", color="#2f8a3c"',
    "Action": 'shape=box, style="rounded,filled", fillcolor="#f1f1f1", color="#777777"',
}
_OTHER = 'shape=box, style="filled", fillcolor="white", color="#999999"'


@dataclass(frozen=True)
class Node:
    kind: str  # the XML tag (Sequence, Condition, Action, ...)
    label: str
    detail: str = ""
    children: tuple[Node, ...] = field(default=())


@dataclass(frozen=True)
class Tree:
    ident: str
    root: Node | None


def read_trees(path: Path) -> list[Tree]:
    """The ``<BehaviorTree>`` elements of one file, in order, without the main tree that only
    sequences the others ([] for a file that is not BT.CPP XML)."""
    try:
        if path.stat().st_size > MAX_XML_BYTES:
            log.warning("%s: larger than %d bytes, not drawn", path, MAX_XML_BYTES)
            return []
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as e:
        log.warning("%s: not drawn (%s)", path, e)
        return []
    trees = []
    every = list(root.iter("BehaviorTree"))
    main = root.get("main_tree_to_execute")
    for bt in every:
        if len(every) > 1 and bt.get("ID") == main:  # the plan's sequence of subtrees
            continue
        kids = list(bt)
        budget = [MAX_NODES]
        node = _node(kids[0], budget) if kids else None
        trees.append(Tree(str(bt.get("ID", "?")), node))
    return trees


def _node(el: ET.Element, budget: list[int]) -> Node:
    budget[0] -= 1
    kind = str(el.tag)
    name = el.get("name") or el.get("ID") or kind
    if kind == "RetryUntilSuccessful":
        label = f"Explore ({el.get('num_attempts', '?')} attempts)"
        detail = name.removeprefix("Explore ")
    elif kind == "Condition":
        label, detail = name, el.get("atom", "")
    elif kind == "Action":
        label = name
        fail = el.get("on_failure")
        detail = f"fails: {fail}" if fail else ""
    else:
        label, detail = (name, "") if kind == "Sequence" else (f"{kind}: {name}", "")
    children = []
    for child in el:
        if not isinstance(child.tag, str):  # a comment
            continue
        if budget[0] <= 0:
            children.append(Node("more", "…"))
            break
        children.append(_node(child, budget))
    return Node(kind, label, detail, tuple(children))


def _quote(s: str) -> str:
    lines = [line[:70] for line in clean(s).splitlines()[:3]]
    s = "\n".join(lines).replace("\\", "\\\\").replace('"', '\\"')
    return '"' + s.replace("\n", "\\n") + '"'


def to_dot(tree: Tree) -> str:
    """Graphviz source of one tree (labels quoted; node names are numbers)."""
    lines = [
        "digraph bt {",
        '  graph [rankdir=LR, ordering=out, nodesep=0.08, ranksep=0.25, bgcolor="transparent"];',
        '  node [fontname="Helvetica", fontsize=10, margin="0.08,0.03", height=0.3];',
        '  edge [color="#888888", arrowsize=0.5];',
    ]
    stack: list[tuple[Node, str | None]] = [(tree.root, None)] if tree.root else []
    count = 0
    while stack:  # depth first, children in order (ordering=out keeps them so)
        node, parent = stack.pop()
        ident = f"n{count}"
        count += 1
        label = node.label + (f"\n{node.detail}" if node.detail else "")
        lines.append(f"  {ident} [label={_quote(label)}, {_STYLE.get(node.kind, _OTHER)}];")
        if parent is not None:
            lines.append(f"  {parent} -> {ident};")
        stack += [(child, ident) for child in reversed(node.children)]
    lines.append("}")
    return "\n".join(lines) + "\n"


def to_svg(tree: Tree) -> bytes | None:
    """The tree drawn by Graphviz as SVG (None: no ``dot``, or it failed or took too long)."""
    dot = shutil.which("dot")
    if dot is None:
        return None
    try:
        done = subprocess.run(
            [dot, "-Tsvg"], input=to_dot(tree).encode(), capture_output=True, timeout=DOT_TIMEOUT
        )
    except (OSError, subprocess.TimeoutExpired) as e:
        log.warning("dot failed on %s: %s", tree.ident, e)
        return None
    if done.returncode != 0:
        log.warning("dot failed on %s: %s", tree.ident, done.stderr[:200])
        return None
    return done.stdout


def to_text(tree: Tree) -> str:
    """The tree as indented text (when it cannot be drawn)."""
    lines: list[str] = []

    def walk(node: Node, depth: int) -> None:
        extra = f"  [{node.detail}]" if node.detail else ""
        lines.append("  " * depth + node.label + extra)
        for child in node.children:
            walk(child, depth + 1)

    if tree.root is not None:
        walk(tree.root, 0)
    return "\n".join(lines)


__all__ = ["Node", "Tree", "read_trees", "to_dot", "to_svg", "to_text"]
