"""Export CSubBTs for people and other tools: BehaviorTree.CPP v4 XML, ASCII, Graphviz.

The exports are built straight from :class:`~llmpas.execution.csubbt.SubtreeSpec` s, so no world
or :class:`~llmpas.execution.context.Context` is needed and nothing touches the py_trees
blackboard. The XML maps a CSubBT onto BehaviorTree.CPP's own nodes::

    <BehaviorTree ID="move_and_pick_cube">
      <RetryUntilSuccessful num_attempts="40">      <- Explore (backtracks until exhausted)
        <Sequence>
          <Sequence name="locate">                 <- one sub-action
            <Condition ID="Check_Detected" atom="(on cube table1)" needs="base;region"/>
            <Action ID="locate" args="cube"/>

Constraint atoms are rendered with ``?dimension`` placeholders for values that are only known
while executing. Every output is deterministic: the same specs give byte-identical text.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees

from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec

log = logging.getLogger(__name__)

# Node types BehaviorTree.CPP registers itself (a leaf must not reuse these IDs).
_BUILTIN_NAMES = (
    "AlwaysFailure AlwaysSuccess Sequence SequenceWithMemory ReactiveSequence Fallback "
    "ReactiveFallback Parallel ParallelAll IfThenElse WhileDoElse Switch2 Switch3 Switch4 "
    "Switch5 Switch6 Inverter RetryUntilSuccessful KeepRunningUntilFailure Repeat Timeout Delay "
    "ForceSuccess ForceFailure ForceRunning RunOnce Precondition SubTree Script ScriptCondition "
    "SetBlackboard Sleep UnsetBlackboard LoopInt LoopDouble LoopString LoopBool "
    "SkipUnlessUpdated WaitValueUpdate Action Condition Control Decorator BehaviorTree "
    "TreeNodesModel root"
)
_BUILTINS = frozenset(_BUILTIN_NAMES.split())
_LEAF_TAGS = ("Action", "Condition")
_CONTROL_CHARS = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


# ---------------------------------------------------------------------------------- identifiers
class _Ids:
    """Maps names to unique identifiers (unique ignoring case, so they also work as file names)."""

    def __init__(self, reserved: Sequence[str]) -> None:
        self._taken = {r.lower() for r in reserved}
        self._given: dict[tuple[str, object], str] = {}

    def get(self, kind: str, key: object, name: str, prefix: str = "") -> str:
        """The identifier of ``(kind, key)``, derived from ``name`` on first use."""
        if (kind, key) in self._given:
            return self._given[(kind, key)]
        base = prefix + (re.sub(r"_+", "_", re.sub(r"\W", "_", name, flags=re.ASCII)).strip("_"))
        if not base or base[0].isdigit():
            base = f"N_{base}"
        ident, n = base, 1
        while ident.lower() in self._taken:
            n += 1
            ident = f"{base}_{n}"
        self._taken.add(ident.lower())
        self._given[(kind, key)] = ident
        return ident


def _clean(text: object) -> str:
    """Text safe for an XML attribute or comment (XML 1.0 forbids most control characters)."""
    return _CONTROL_CHARS.sub("?", str(text))


class _Symbolic(dict[str, Any]):
    """Plan bindings; every other value reads as a ``?name`` placeholder."""

    def __missing__(self, key: str) -> str:
        return f"?{key}"


def _atom_text(c: Constraint, spec: SubtreeSpec) -> str:
    try:
        return str(c.atom(_Symbolic(spec.fixed)))
    except Exception as e:  # an atom that needs real values: show the name only
        log.debug("atom of %s not renderable without values: %s", c.name, e)
        return ""


# ---------------------------------------------------------------------------------- layout
@dataclass
class _Layout:
    main: str
    trees: list[tuple[str, SubtreeSpec]]
    ids: _Ids
    ports: dict[tuple[str, str], set[str]] = field(default_factory=dict)  # (tag, ID) -> ports

    def leaf(self, tag: str, ident: str, attrs: Mapping[str, str]) -> ET.Element:
        ports = self.ports.setdefault((tag, ident), set())
        ports.update(k for k in attrs if k != "name")
        el = ET.Element(tag, {"ID": ident})
        el.attrib.update({k: _clean(v) for k, v in attrs.items()})
        return el


def _layout(specs: Sequence[SubtreeSpec], main: str) -> _Layout:
    if not specs:
        raise ValueError("a plan needs at least one CSubBT")
    if not main.isidentifier() or main in _BUILTINS:
        raise ValueError(f"main tree ID {main!r} must be an identifier and not a built-in name")
    ids = _Ids([*_BUILTINS, main, "plan"])  # "plan": no CSubBT file may be named plan.xml
    # keyed by position as well: two CSubBTs with one label still get two IDs
    trees = [(ids.get("tree", i, s.label), s) for i, s in enumerate(specs)]
    return _Layout(main, trees, ids)


def _condition(lay: _Layout, spec: SubtreeSpec, c: Constraint) -> ET.Element:
    attrs = {"name": f"{c.name}?", "constraint": c.name, "needs": ";".join(c.needs)}
    if atom := _atom_text(c, spec):
        attrs["atom"] = atom
    if c.resample != c.needs:
        attrs["resample"] = ";".join(c.resample)
    return lay.leaf("Condition", lay.ids.get("condition", c.name, c.name, "Check_"), attrs)


def _action(lay: _Layout, spec: SubtreeSpec, sa: SubAction) -> ET.Element:
    attrs = {"name": sa.name, "needs": ";".join(sa.needs), "args": " ".join(spec.args)}
    if sa.on_failure is not None:
        atom = _atom_text(sa.on_failure, spec)
        attrs["on_failure"] = f"{sa.on_failure.name} {atom}".strip()
    return lay.leaf("Action", lay.ids.get("action", sa.name, sa.name), attrs)


def _comment(spec: SubtreeSpec) -> ET.Element[Any]:
    steps = ", ".join(map(str, spec.steps)) or "none"
    dims = ", ".join(d.name for d in spec.dims) or "none"
    text = f" {spec.action}({', '.join(spec.args)}): plan steps {steps}; dimensions {dims} "
    return ET.Comment(_clean(text).replace("--", "- -"))


def _behavior_tree(lay: _Layout, ident: str, spec: SubtreeSpec) -> ET.Element:
    bt = ET.Element("BehaviorTree", {"ID": ident})
    bt.append(_comment(spec))
    retry = ET.SubElement(
        bt,
        "RetryUntilSuccessful",
        {"name": _clean(f"Explore {spec.label}"), "num_attempts": str(spec.max_samples)},
    )
    body = ET.SubElement(retry, "Sequence", {"name": _clean(f"{spec.label} steps")})
    for sa in spec.sub_actions:
        seq = ET.SubElement(body, "Sequence", {"name": _clean(sa.name)})
        seq.extend(_condition(lay, spec, c) for c in sa.constraints)
        seq.append(_action(lay, spec, sa))
    return bt


def _main_tree(lay: _Layout) -> ET.Element:
    bt = ET.Element("BehaviorTree", {"ID": lay.main})
    seq = ET.SubElement(bt, "Sequence", {"name": "plan"})
    for ident, spec in lay.trees:
        ET.SubElement(seq, "SubTree", {"ID": ident, "name": _clean(spec.label)})
    return bt


def _nodes_model(lay: _Layout, used: set[tuple[str, str]]) -> ET.Element:
    model = ET.Element("TreeNodesModel")
    for tag, ident in sorted(used):
        el = ET.SubElement(model, tag, {"ID": ident})
        for port in sorted(lay.ports[(tag, ident)]):
            ET.SubElement(el, "input_port", {"name": port})
    return model


def _document(lay: _Layout, main: str, trees: list[ET.Element]) -> str:
    root = ET.Element("root", {"BTCPP_format": "4", "main_tree_to_execute": main})
    root.extend(trees)
    used = {(el.tag, el.attrib["ID"]) for t in trees for el in t.iter() if el.tag in _LEAF_TAGS}
    root.append(_nodes_model(lay, used))
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


# ---------------------------------------------------------------------------------- public XML
def to_btcpp_files(specs: Sequence[SubtreeSpec], main: str = "Plan") -> dict[str, str]:
    """File name -> BehaviorTree.CPP v4 XML: ``plan.xml`` (every CSubBT + the main tree) and
    ``<ID>.xml`` per CSubBT (that tree alone, loadable on its own)."""
    lay = _layout(specs, main)
    trees = [_behavior_tree(lay, ident, spec) for ident, spec in lay.trees]
    files = {"plan.xml": _document(lay, main, [*trees, _main_tree(lay)])}
    for (ident, _), tree in zip(lay.trees, trees, strict=True):
        files[f"{ident}.xml"] = _document(lay, ident, [tree])
    return files


def to_btcpp_xml(specs: Sequence[SubtreeSpec], main: str = "Plan") -> str:
    """BehaviorTree.CPP v4 XML of a plan: one ``<BehaviorTree>`` per CSubBT and a main tree
    ``main`` that runs them in order through ``<SubTree>`` nodes."""
    return to_btcpp_files(specs, main)["plan.xml"]


def leaf_ids(xml: str) -> tuple[set[str], set[str]]:
    """The IDs of the ``<Action>`` and of the ``<Condition>`` nodes used in the trees of ``xml``."""
    root = ET.fromstring(xml)
    actions: set[str] = set()
    conditions: set[str] = set()
    for tree in root.iter("BehaviorTree"):
        actions.update(el.attrib["ID"] for el in tree.iter("Action") if "ID" in el.attrib)
        conditions.update(el.attrib["ID"] for el in tree.iter("Condition") if "ID" in el.attrib)
    return actions, conditions


def _btcpp() -> Any:
    try:
        import behaviortreepy
    except ImportError as e:
        raise ImportError(
            "loading XML in BehaviorTree.CPP needs behaviortreepy (its Python bindings): "
            "pip install 'behaviortreepy==0.1.4', or pip install -e '.[test]'"
        ) from e
    return behaviortreepy


def _factory(bt: Any, xml: str, ticked: list[str]) -> Any:
    """A factory knowing every leaf ID of ``xml`` as a simple node that succeeds."""
    try:
        actions, conditions = leaf_ids(xml)
    except ET.ParseError:  # let BT.CPP report the malformed text in its own words
        actions, conditions = set(), set()

    def leaf(node: Any) -> Any:
        ticked.append(str(node.name()))
        return bt.NodeStatus.SUCCESS

    factory = bt.BehaviorTreeFactory()
    for ident in sorted(actions):
        factory.register_simple_action(ident, leaf)
    for ident in sorted(conditions):
        factory.register_simple_condition(ident, leaf)
    return factory


def _without_ports(xml: str) -> tuple[str, str]:
    """``xml`` without the leaves' port attributes (simple nodes declare no ports, so BT.CPP
    cannot instantiate them otherwise), and the name of its main tree."""
    root = ET.fromstring(xml)
    for tree in root.iter("BehaviorTree"):
        for el in tree.iter():
            if el.tag in _LEAF_TAGS:
                el.attrib = {k: v for k, v in el.attrib.items() if k in ("ID", "name")}
    trees = [t.attrib.get("ID", "") for t in root.iter("BehaviorTree")]
    main = root.attrib.get("main_tree_to_execute") or (trees[0] if len(trees) == 1 else "")
    if not main:
        raise RuntimeError("the XML names no main_tree_to_execute and has several trees")
    return ET.tostring(root, "unicode"), main


def _instantiate(bt: Any, xml: str, ticked: list[str]) -> Any:
    text, main = _without_ports(xml)
    try:
        factory = _factory(bt, text, ticked)
        factory.register_behavior_tree_from_text(text)
        return factory.create_tree(main)
    except RuntimeError as e:
        raise RuntimeError(f"BehaviorTree.CPP could not instantiate tree {main!r}: {e}") from e


def load_in_btcpp(xml: str, instantiate: bool = True) -> None:
    """Load ``xml`` with BehaviorTree.CPP (through ``behaviortreepy``).

    Every leaf ID is registered as a simple node, then BT.CPP parses and verifies the text,
    port attributes included. With ``instantiate``, BT.CPP also builds the main tree (from a copy
    without the leaves' port attributes), which checks ``<SubTree>`` references and the
    parameters of built-in nodes such as ``num_attempts``. Raises RuntimeError with BT.CPP's
    message when it rejects the XML.
    """
    bt = _btcpp()
    try:
        _factory(bt, xml, []).register_behavior_tree_from_text(xml)
    except RuntimeError as e:
        raise RuntimeError(f"BehaviorTree.CPP rejected the XML: {e}") from e
    if instantiate:
        _instantiate(bt, xml, [])


def dry_run_in_btcpp(xml: str) -> list[str]:
    """Load ``xml`` and tick its main tree once in BehaviorTree.CPP with every leaf succeeding;
    returns the names of the leaves in the order BT.CPP ticked them."""
    bt = _btcpp()
    load_in_btcpp(xml, instantiate=False)
    ticked: list[str] = []
    status = _instantiate(bt, xml, ticked).tick_once()
    if status != bt.NodeStatus.SUCCESS:
        raise RuntimeError(f"BehaviorTree.CPP dry run ended with {status}, expected SUCCESS")
    return ticked


# ---------------------------------------------------------------------------------- ASCII / dot
@dataclass(frozen=True)
class _Shown:
    kind: str  # explore | sequence | check | act
    text: str
    detail: str = ""
    children: tuple[_Shown, ...] = ()

    def line(self, sep: str = " ") -> str:
        return f"{self.text}{sep}{self.detail}" if self.detail else self.text


def _needs(names: Sequence[str]) -> str:
    return f"(needs {', '.join(names)})" if names else ""


def _shown(spec: SubtreeSpec) -> _Shown:
    parts = []
    for sa in spec.sub_actions:
        leaves = [
            _Shown("check", f"Check {c.name}? {_atom_text(c, spec)}".rstrip(), _needs(c.needs))
            for c in sa.constraints
        ]
        detail = _needs(sa.needs)
        if sa.on_failure is not None:
            fail = f"[on failure: {sa.on_failure.name} {_atom_text(sa.on_failure, spec)}]"
            detail = f"{detail} {fail}".strip()
        leaves.append(_Shown("act", f"Act {sa.name}", detail))
        parts.append(_Shown("sequence", f"Sequence {sa.name}", children=tuple(leaves)))
    body = _Shown("sequence", f"Sequence {spec.label} steps", children=tuple(parts))
    dims = ", ".join(d.name for d in spec.dims) or "no dimensions"
    detail = (
        f"[{spec.action}({', '.join(spec.args)}); up to {spec.max_samples} samples over {dims}]"
    )
    return _Shown("explore", f"Explore {spec.label}", detail, (body,))


def _ascii_lines(node: _Shown, prefix: str, last: bool, top: bool) -> list[str]:
    lines = [node.line() if top else f"{prefix}{'`-- ' if last else '|-- '}{node.line()}"]
    inner = "" if top else prefix + ("    " if last else "|   ")
    for i, child in enumerate(node.children):
        lines += _ascii_lines(child, inner, i == len(node.children) - 1, False)
    return lines


def to_ascii(spec_or_tree: SubtreeSpec | py_trees.behaviour.Behaviour) -> str:
    """A plain-ASCII tree: of a spec (with constraint atoms and needed dimensions), or of a built
    py_trees tree (``py_trees.display.ascii_tree``)."""
    if isinstance(spec_or_tree, py_trees.behaviour.Behaviour):
        return str(py_trees.display.ascii_tree(spec_or_tree))
    lines = _ascii_lines(_shown(spec_or_tree), "", True, True)
    return "\n".join(_clean(line) for line in lines) + "\n"


_DOT_STYLE = {
    "explore": 'shape=hexagon, fillcolor="gold"',
    "sequence": 'shape=box, fillcolor="orange"',
    "check": 'shape=ellipse, fillcolor="lightblue"',
    "act": 'shape=box, style="rounded,filled", fillcolor="gray85"',
}


def _dot_quote(text: str) -> str:
    return '"' + _clean(text).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def to_dot(spec: SubtreeSpec) -> str:
    """Graphviz dot source of one CSubBT (nodes are numbered; names only appear in labels)."""
    lines = [
        f"digraph {_dot_quote(spec.label)} {{",
        "  ordering=out;",
        '  node [style=filled, fontname="Helvetica", fontsize=10];',
    ]
    count = 0

    def walk(node: _Shown) -> str:
        nonlocal count
        ident = f"n{count}"
        count += 1
        label = _dot_quote(node.line("\n"))
        lines.append(f"  {ident} [label={label}, {_DOT_STYLE[node.kind]}];")
        for child in node.children:
            lines.append(f"  {ident} -> {walk(child)};")
        return ident

    walk(_shown(spec))
    lines.append("}")
    return "\n".join(lines) + "\n"


class GraphvizNotFound(RuntimeError):
    """The Graphviz ``dot`` program is not installed."""


def render_png(spec: SubtreeSpec, path: str | Path) -> Path:
    """Render the CSubBT as a PNG with Graphviz ``dot`` (written atomically)."""
    dot = shutil.which("dot")
    if dot is None:
        raise GraphvizNotFound(
            "render_png needs the Graphviz 'dot' program, which is not on PATH; install "
            "graphviz (e.g. apt-get install graphviz)"
        )
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        done = subprocess.run(
            [dot, "-Tpng", "-o", tmp],
            input=to_dot(spec),
            capture_output=True,
            text=True,
            timeout=120,
        )
        if done.returncode != 0:
            raise RuntimeError(f"dot failed ({done.returncode}): {done.stderr.strip()}")
        os.chmod(tmp, 0o644)  # mkstemp creates 0600
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)
    return path


__all__ = [
    "GraphvizNotFound",
    "dry_run_in_btcpp",
    "leaf_ids",
    "load_in_btcpp",
    "render_png",
    "to_ascii",
    "to_btcpp_files",
    "to_btcpp_xml",
    "to_dot",
]
