"""Exporting CSubBTs: BehaviorTree.CPP v4 XML (loaded by BT.CPP itself), ASCII, dot and PNG."""

from __future__ import annotations

import re
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest

from llmpas.execution.context import Belief, Context
from llmpas.execution.csubbt import Constraint, SubAction, SubtreeSpec, build_subtree
from llmpas.execution.export import (
    GraphvizNotFound,
    dry_run_in_btcpp,
    leaf_ids,
    load_in_btcpp,
    render_png,
    to_ascii,
    to_btcpp_files,
    to_btcpp_xml,
    to_dot,
)
from llmpas.execution.robot_protocols import SkillResult
from llmpas.execution.space import Dimension
from llmpas.language.logic import Atom

from ..system_packages import needs_dot
from .toy import ToyWorld, pick_spec

IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def ok(v: Any, ctx: Context) -> SkillResult:
    return SkillResult.success()


def place_spec(label: str = "place cube table2") -> SubtreeSpec:
    holding = Constraint(
        "Holding",
        lambda v, c: None if c.robot.holding() == v["obj"] else f"not holding {v['obj']}",
        lambda v: Atom("holding", (v["obj"],)),
    )
    free = Constraint(
        "PoseFree",
        lambda v, c: None,
        lambda v: Atom("free", (v["surface"], v["pose"])),  # "pose" is a dimension
        needs=("pose",),
    )
    subs = (
        SubAction("move_base", lambda v, c: c.robot.move_base(v["base"]), needs=("base",)),
        SubAction(
            "release",
            lambda v, c: c.robot.release(v["obj"], v["pose"]),
            constraints=(holding, free),
            needs=("pose",),
        ),
    )
    dims = (Dimension("base", lambda v: ["q3"]), Dimension("pose", lambda v: ["p1", "p2"]))
    fixed = {"obj": "cube", "surface": "table2"}
    return SubtreeSpec(label, (2,), "place", ("cube", "table2"), fixed, dims, subs, max_samples=9)


def plan() -> list[SubtreeSpec]:
    return [pick_spec(), place_spec()]


def trees(xml: str) -> dict[str, ET.Element]:
    return {t.attrib["ID"]: t for t in ET.fromstring(xml).iter("BehaviorTree")}


def in_trees(xml: str, tag: str) -> list[ET.Element]:
    """``tag`` elements inside the trees (not the TreeNodesModel)."""
    return [el for t in trees(xml).values() for el in t.iter(tag)]


# ---------------------------------------------------------------------------------- XML
def test_plan_xml_has_one_behavior_tree_per_csubbt_and_a_main_sequence() -> None:
    xml = to_btcpp_xml(plan())
    root = ET.fromstring(xml)
    assert root.tag == "root" and root.attrib["BTCPP_format"] == "4"
    assert root.attrib["main_tree_to_execute"] == "Plan"
    ids = [t.attrib["ID"] for t in root.iter("BehaviorTree")]
    assert len(ids) == len(set(ids)) == 3 and all(IDENT.fullmatch(i) for i in ids)
    main = trees(xml)["Plan"]
    (seq,) = list(main)
    assert seq.tag == "Sequence"
    assert [(s.tag, s.attrib["ID"]) for s in seq] == [("SubTree", i) for i in ids[:2]]
    assert [s.attrib["name"] for s in seq] == ["move-and-pick cube", "place cube table2"]


def test_csubbt_maps_to_retry_over_a_sequence_of_sub_action_sequences() -> None:
    xml = to_btcpp_xml(plan())
    pick = trees(xml)["move_and_pick_cube"]
    (retry,) = [el for el in pick if el.tag != ET.Comment]
    assert retry.tag == "RetryUntilSuccessful" and retry.attrib["num_attempts"] == "40"
    (body,) = list(retry)
    assert body.tag == "Sequence"
    assert [s.attrib["name"] for s in body] == ["move_base", "locate", "grasp"]
    locate = body[1]
    check, act = list(locate)
    assert check.tag == "Condition" and check.attrib["ID"] == "Check_Detected"
    assert check.attrib["atom"] == "(on cube table1)" and check.attrib["needs"] == "base;region"
    assert act.tag == "Action" and act.attrib["ID"] == "locate" and act.attrib["args"] == "cube"
    grasp = body[2][0]
    assert grasp.attrib["needs"] == "grasp"
    assert grasp.attrib["on_failure"] == "Grasped (holding cube)"
    place = trees(xml)["place_cube_table2"]
    assert place.find("RetryUntilSuccessful").attrib["num_attempts"] == "9"  # type: ignore[union-attr]


def test_atoms_use_plan_bindings_and_placeholders_for_sampled_values() -> None:
    xml = to_btcpp_xml([place_spec()])
    conds = {c.attrib["ID"]: c.attrib for c in in_trees(xml, "Condition")}
    assert conds["Check_Holding"]["atom"] == "(holding cube)"  # fixed binding
    assert conds["Check_PoseFree"]["atom"] == "(free table2 ?pose)"  # drawn while executing


def test_an_atom_that_needs_real_values_is_left_out_not_fatal() -> None:
    odd = Constraint("Near", lambda v, c: None, lambda v: Atom("near", (str(v["d"] + 1),)))
    spec = SubtreeSpec("go", (0,), "go", (), {}, (), (SubAction("go", ok, constraints=(odd,)),))
    xml = to_btcpp_xml([spec])
    (cond,) = in_trees(xml, "Condition")
    assert cond.attrib["constraint"] == "Near" and "atom" not in cond.attrib
    load_in_btcpp(xml)


def test_tree_nodes_model_declares_every_leaf_with_its_ports_once() -> None:
    xml = to_btcpp_xml(plan())
    root = ET.fromstring(xml)
    model = root.find("TreeNodesModel")
    assert model is not None
    declared = {(el.tag, el.attrib["ID"]): el for el in model}
    used: dict[tuple[str, str], set[str]] = {}
    for tree in root.iter("BehaviorTree"):
        for el in tree.iter():
            if el.tag in ("Action", "Condition"):
                ports = set(el.attrib) - {"ID", "name"}
                used.setdefault((el.tag, el.attrib["ID"]), set()).update(ports)
    assert set(declared) == set(used)
    assert len(model) == len(declared)  # move_base is used twice, declared once
    for key, el in declared.items():
        assert {p.attrib["name"] for p in el.iter("input_port")} == used[key]
    assert leaf_ids(xml) == (
        {"move_base", "locate", "grasp", "release"},
        {"Check_Detected", "Check_Holding", "Check_PoseFree"},
    )


def test_plan_loads_and_runs_in_behaviortree_cpp() -> None:
    xml = to_btcpp_xml(plan())
    load_in_btcpp(xml)
    ticked = dry_run_in_btcpp(xml)
    assert ticked == [
        "move_base",
        "Detected?",
        "locate",
        "grasp",
        "move_base",
        "Holding?",
        "PoseFree?",
        "release",
    ]


def test_each_csubbt_file_loads_on_its_own() -> None:
    files = to_btcpp_files(plan())
    assert list(files) == ["plan.xml", "move_and_pick_cube.xml", "place_cube_table2.xml"]
    assert files["plan.xml"] == to_btcpp_xml(plan())
    for name, xml in files.items():
        load_in_btcpp(xml)
        if name != "plan.xml":
            assert list(trees(xml)) == [name.removesuffix(".xml")]
    assert dry_run_in_btcpp(files["place_cube_table2.xml"])[-1] == "release"


def test_btcpp_rejects_an_unregistered_node() -> None:
    xml = to_btcpp_xml(plan()).replace(
        '<Sequence name="locate">', '<Sequence name="locate"><Teleport to="moon" />'
    )
    with pytest.raises(RuntimeError, match=r"Node not recognized: Teleport"):
        load_in_btcpp(xml)


def test_btcpp_rejects_malformed_xml() -> None:
    xml = to_btcpp_xml(plan())
    with pytest.raises(RuntimeError, match=r"Error parsing the XML: Error=XML_ERROR"):
        load_in_btcpp(xml[: len(xml) // 2])


def test_btcpp_rejects_a_missing_subtree_and_a_bad_attempt_count() -> None:
    xml = to_btcpp_xml(plan())
    with pytest.raises(RuntimeError, match=r"Can't find a tree with name: Missing"):
        load_in_btcpp(xml.replace('SubTree ID="place_cube_table2"', 'SubTree ID="Missing"'))
    with pytest.raises(RuntimeError, match=r"num_attempts.*can not be converted to int"):
        load_in_btcpp(xml.replace('num_attempts="40"', 'num_attempts="many"'))


def test_missing_behaviortreepy_gives_install_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "behaviortreepy", None)
    with pytest.raises(ImportError, match=r"pip install 'behaviortreepy"):
        load_in_btcpp(to_btcpp_xml(plan()))


def test_export_is_deterministic() -> None:
    assert to_btcpp_xml(plan()) == to_btcpp_xml(plan())
    assert to_btcpp_files(plan()) == to_btcpp_files(plan())
    assert to_dot(pick_spec()) == to_dot(pick_spec())
    assert to_ascii(pick_spec()) == to_ascii(pick_spec())


def odd_spec() -> SubtreeSpec:
    weird = Constraint(
        'Reach "ok" <1m>', lambda v, c: None, lambda v: Atom("near", ("a<b", 'say "hi"', "x&y"))
    )
    sub = SubAction("grab & go <fast>", ok, constraints=(weird,))
    return SubtreeSpec('pick "big" <cube> & co', (0,), "pick", ("big cube", "<t>"), {}, (), (sub,))


def test_odd_names_are_escaped_and_ids_stay_identifiers() -> None:
    xml = to_btcpp_xml(
        [odd_spec(), pick_spec(label="a b"), pick_spec(label="a-b"), pick_spec(label="plan")]
    )
    root = ET.fromstring(xml)
    ids = [t.attrib["ID"] for t in root.iter("BehaviorTree")]
    assert all(IDENT.fullmatch(i) for i in ids) and len({i.lower() for i in ids}) == len(ids)
    cond = in_trees(xml, "Condition")[0]
    assert cond.attrib["name"] == 'Reach "ok" <1m>?'
    assert cond.attrib["atom"] == '(near a<b say "hi" x&y)'
    assert IDENT.fullmatch(cond.attrib["ID"])
    act = in_trees(xml, "Action")[0]
    assert act.attrib["name"] == "grab & go <fast>" and act.attrib["args"] == "big cube <t>"
    assert next(root.iter("SubTree")).attrib["name"] == 'pick "big" <cube> & co'
    assert "<cube>" not in xml and "&lt;cube&gt;" in xml
    load_in_btcpp(xml)
    files = to_btcpp_files([pick_spec(label="plan"), pick_spec(label="Plan")])
    assert len(files) == 3 and len({n.lower() for n in files}) == 3  # no plan.xml clash


def test_leaf_named_like_a_builtin_node_gets_its_own_id() -> None:
    spec = SubtreeSpec("Sequence", (0,), "x", (), {}, (), (SubAction("Sequence", ok),))
    xml = to_btcpp_xml([spec])
    (action,) = leaf_ids(xml)[0]
    assert action != "Sequence" and IDENT.fullmatch(action) and action.startswith("Sequence_")
    assert dry_run_in_btcpp(xml) == ["Sequence"]


def test_main_tree_name_is_checked() -> None:
    with pytest.raises(ValueError, match="built-in"):
        to_btcpp_xml(plan(), main="Sequence")
    with pytest.raises(ValueError, match="at least one"):
        to_btcpp_xml([])


# ---------------------------------------------------------------------------------- ASCII / dot
def test_ascii_shows_every_sub_action_and_constraint() -> None:
    text = to_ascii(pick_spec())
    for part in ("move_base", "locate", "grasp", "Detected?", "(on cube table1)", "Grasped"):
        assert part in text
    assert text.isascii()
    lines = text.splitlines()
    assert lines[0].startswith("Explore move-and-pick cube") and len(lines) == 9
    assert lines.index("    |   |-- Check Detected? (on cube table1) (needs base, region)") == 5


def test_ascii_of_a_built_py_trees_subtree() -> None:
    world = ToyWorld("t1a")
    ctx = Context(world, world, Belief([], {}), np.random.default_rng(0))
    text = to_ascii(build_subtree(pick_spec(), ctx, "k"))
    assert "move-and-pick cube" in text and "Detected?" in text and "grasp" in text


def test_dot_source_has_a_node_per_tree_node() -> None:
    src = to_dot(pick_spec())
    labels = re.findall(r'label="((?:[^"\\]|\\.)*)"', src)
    assert len(labels) == 9  # explore, body, 3 sub-actions, 1 check, 3 acts
    assert any(lab.startswith("Check Detected? (on cube table1)") for lab in labels)
    assert len(re.findall(r"->", src)) == 8
    odd = to_dot(odd_spec())
    assert r"pick \"big\" <cube> & co" in odd


@needs_dot
def test_render_png_writes_a_real_image(tmp_path: Path) -> None:
    from PIL import Image, ImageStat

    path = render_png(pick_spec(), tmp_path / "pick.png")
    assert path.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    with Image.open(path) as img:
        assert img.width > 200 and img.height > 100
        assert ImageStat.Stat(img.convert("L")).var[0] > 0
    assert [p.name for p in tmp_path.iterdir()] == ["pick.png"]


@needs_dot
def test_render_png_copes_with_odd_names(tmp_path: Path) -> None:
    assert render_png(odd_spec(), tmp_path / "odd.png").stat().st_size > 0


def test_render_png_names_the_missing_dot_program(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    with pytest.raises(GraphvizNotFound, match=r"Graphviz 'dot' program"):
        render_png(pick_spec(), tmp_path / "x.png")
    assert list(tmp_path.iterdir()) == []
