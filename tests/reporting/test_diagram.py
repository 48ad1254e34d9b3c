"""CSubBT diagrams drawn from the BehaviorTree.CPP XML on disk."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from llmpas.reporting import diagram

from ..system_packages import needs_dot


def test_every_subtree_of_the_main_job_is_read_with_its_constraints(main_job: Path) -> None:
    files = sorted(p for p in (main_job / "round-0").glob("*.xml") if p.name != "plan.xml")
    trees = [t for f in files for t in diagram.read_trees(f)]
    assert len(trees) == len(files) == 2
    pick = next(t for t in trees if "pick" in t.ident)
    dot = diagram.to_dot(pick)
    xml = ET.parse(next(f for f in files if "pick" in f.name)).getroot()
    atoms = {el.get("atom") for el in xml.iterfind("BehaviorTree//Condition")}
    assert atoms and all(a and a in dot for a in atoms)
    assert dot.count("->") == dot.count("[label=") - 1  # a tree: one parent per node but one


@needs_dot
def test_hostile_names_are_quoted_for_graphviz(tmp_path: Path) -> None:
    f = tmp_path / "bt.xml"
    f.write_text(
        '<root><BehaviorTree ID="x"><Sequence name="a&quot;]; n9 [label=&quot;pwn">'
        '<Action name="\\&quot;\\" ID="b"/></Sequence></BehaviorTree></root>'
    )
    (tree,) = diagram.read_trees(f)
    svg = diagram.to_svg(tree)
    assert svg is not None and svg.count(b'class="node"') == 2  # no node was injected
    assert b"pwn" in svg  # the name is shown, as text


def test_large_deep_and_broken_files_are_bounded(tmp_path: Path) -> None:
    wide = tmp_path / "wide.xml"
    leaves = "".join(f'<Action name="a{i}"/>' for i in range(2 * diagram.MAX_NODES))
    wide.write_text(
        f'<root><BehaviorTree ID="w"><Sequence>{leaves}</Sequence></BehaviorTree></root>'
    )
    (tree,) = diagram.read_trees(wide)
    assert diagram.to_dot(tree).count("[label=") <= diagram.MAX_NODES + 2
    broken = tmp_path / "broken.xml"
    broken.write_text("<root><BehaviorTree>")
    assert diagram.read_trees(broken) == []
    laughs = tmp_path / "laughs.xml"
    entities = "".join(f'<!ENTITY e{i} "{f"&e{i - 1};" * 10 if i else "lol"}">' for i in range(10))
    laughs.write_text(f'<!DOCTYPE r [{entities}]><root><BehaviorTree ID="&e9;"/></root>')
    assert diagram.read_trees(laughs) == []  # expat refuses the expansion
    assert diagram.read_trees(tmp_path / "missing.xml") == []
