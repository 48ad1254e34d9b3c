"""Site files: the shipped ones load; every bad field is one line naming the file and the key;
``llmpas run --site`` with a bad site ends with that line, a non-zero exit and no traceback."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from llmpas.worlds.ros2.site import Region, SiteError, load, parse, shipped

REPO = Path(__file__).resolve().parents[3]

GOOD = """\
frame: map
places:
  bench:
    box: {center: [2.0, 0.0], size: [0.6, 1.2], height: 0.7}
    reach: [[1.3, 0.0, 0.0]]
  bin:
    kind: container
    openable: true
    polygon: [[-1, -1], [-0.5, -1], [-0.5, -0.5], [-1, -0.5]]
    height: 0.3
    reach: [[0.0, -0.75, 3.14]]
    look: [[0.1, -0.75, 3.14]]
furniture:
  bench: {size: [0.6, 1.2, 0.7], pose: [2.0, 0.0, 0.35, 0.0]}
classes:
  mug: {shape: box, size: [0.06, 0.06, 0.06]}
objects:
  mug: {class: mug, place: bench, at: [2.1, 0.2]}
  spoon: {class: mug}
tasks:
  tidy: {goal: "(and (On mug bin))"}
"""


def write(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "site.yaml"
    f.write_text(text)
    return f


def test_the_shipped_sites_load() -> None:
    found = shipped()
    assert "house" in found
    house = load("house")
    assert [p.name for p in house.places] == ["table1", "table2", "table3", "table4"]
    assert house.place_of(1.27, 0.15) == "table1" and house.place_of(0.0, 0.0) is None
    assert house.task("object-loss").goal == "(and (On cube bowl))"
    assert {o.name: o.place for o in house.objects} == {"cube": "table1", "bowl": "table2"}
    assert house.cls("bowl").shape == "container" and not house.cls("bowl").graspable
    workshop = load("workshop")  # written apart: other names, sizes and layout
    assert {p.name for p in workshop.places} == {"workbench", "counter", "cart"}
    assert workshop.place("counter").region.axis_aligned  # a polygon, measured corner by corner
    assert workshop.place_of(1.7, 0.55) == "counter" and workshop.cls("block").size[0] == 0.04


PLANNABLE = (
    GOOD.replace("height: 0.7", "height: 0.625")
    .replace("    kind: container\n    openable: true\n", "")
    .replace("height: 0.3", "height: 0.625")
)


@pytest.mark.parametrize(
    ("change", "key"),
    [
        (("  bin:\n", "  bin:\n    kind: container\n"),
         "places.bin.kind: the planner plans on surfaces only"),
        (("height: 0.625}", "height: 0.8}"), "places.bench: height 0.8"),
        (("size: [0.06, 0.06, 0.06]", "size: [0.06, 0.03, 0.06]"), "classes.mug.size: the planner"),
        (("  mug: {class: mug, place: bench", "  mug: {class: mug, colour: mauve, place: bench"),
         "objects.mug.colour: one of"),
        (("polygon: [[-1, -1], [-0.5, -1]", "polygon: [[-1, -1], [-0.4, -1]"),
         "places.bin: the planner samples placements on axis-aligned rectangles"),
    ],
)  # fmt: skip
def test_what_the_planner_cannot_plan_for_is_named(change: tuple[str, str], key: str) -> None:
    from llmpas.worlds.ros2.site_scene import scene_config

    scene_config(parse(yaml.safe_load(PLANNABLE), "good.yaml"), (0.0, 0.0, 0.0))  # plannable
    assert change[0] in PLANNABLE
    site = parse(yaml.safe_load(PLANNABLE.replace(*change)), "good.yaml")
    with pytest.raises(SiteError) as e:
        scene_config(site, (0.0, 0.0, 0.0))
    assert str(e.value).startswith("good.yaml: ") and key in str(e.value), str(e.value)


def test_a_site_as_the_planners_scene() -> None:
    from llmpas.worlds.ros2.site_scene import scene_config

    config = scene_config(load("workshop"), (0.0, 0.0, 1.5708))
    assert [t.name for t in config.tables] == ["workbench", "counter", "cart"]
    block = config.obj("block")
    assert (block.kind, block.table, block.colour, block.size) == (
        "cube",
        "workbench",
        "blue",
        0.04,
    )
    assert (block.dx, block.dy) == (0.25, -0.15)  # told: [0.25, 1.55] on the workbench
    assert config.obj("tray").kind == "bowl" and config.base == (0.0, 0.0, 1.5708)


def test_a_site_with_a_polygon_a_container_and_an_object_without_place(tmp_path: Path) -> None:
    site = load(write(tmp_path, GOOD))
    bin_ = site.place("bin")
    assert bin_.kind == "container" and bin_.openable and bin_.region.axis_aligned
    assert bin_.views[0].x == pytest.approx(0.1)  # its look pose, not its reach pose
    assert site.place("bench").views == site.place("bench").reach  # none given: reach
    assert site.place_of(-0.7, -0.7) == "bin" and site.place_of(2.0, 0.5) == "bench"
    assert site.place_of(2.0, 0.7) is None
    spoon = next(o for o in site.objects if o.name == "spoon")
    assert spoon.place == "" and spoon.at is None  # told of, whereabouts unknown
    assert site.source.endswith("site.yaml")


def test_a_turned_box_and_a_polygon_that_is_not_a_rectangle() -> None:
    turned = Region.box((0.0, 0.0), (2.0, 1.0), 0.5, yaw=0.7)
    assert turned.contains(0.9 * 0.76, 0.9 * 0.64) and not turned.axis_aligned
    assert abs(turned.area) == pytest.approx(2.0)
    l_shape = Region(((0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)), 0.4)
    assert l_shape.contains(0.5, 1.5) and not l_shape.contains(1.5, 1.5)


def edit(old: str, new: str) -> str:
    assert old in GOOD
    return GOOD.replace(old, new)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (edit("    reach: [[1.3, 0.0, 0.0]]\n", ""),
         "places.bench.reach: no base pose to reach it"),
        (edit("    reach: [[1.3, 0.0, 0.0]]\n", "    reach: []\n"), "places.bench.reach: no base"),
        (edit("(On mug bin)", "(On mug shelf)"),
         "tasks.tidy.goal: unknown place or object 'shelf'"),
        (edit("place: bench, at", "place: garage, at"), "objects.mug.place: no place 'garage'"),
        (edit("{class: mug, place", "{clas: mug, place"), "objects.mug.clas: unknown key"),
        (edit("  spoon: {class: mug}\n", "  spoon: {place: bench}\n"),
         "objects.spoon.class: missing"),
        (edit("  spoon: {class: mug}\n", "  spoon: {class: fork}\n"),
         "objects.spoon.class: no class 'fork'"),
        (edit("at: [2.1, 0.2]", "at: [5.0, 0.2]"), "objects.mug.at: [5.0, 0.2] is not on bench"),
        (edit("size: [0.6, 1.2], height: 0.7", "size: [0.6, 1.2]"),
         "places.bench.box.height: missing"),
        (edit("center: [2.0, 0.0], ", ""), "places.bench.box.center: missing"),
        (edit("    height: 0.3\n", ""), "places.bin.height: missing"),
        (edit("kind: container", "kind: shelf"), "places.bin.kind: one of surface, container"),
        (edit("    kind: container\n", ""), "places.bin.openable: only a container opens"),
        (edit("reach: [[1.3, 0.0, 0.0]]", "reach: [[1.3, 0.0]]"),
         "places.bench.reach[0]: a list of 3 numbers"),
        (edit("height: 0.7", "height: high"), "places.bench.box.height: a number"),
        (edit("size: [0.6, 1.2], height", "size: [0.6, -1.2], height"),
         "places.bench.box: size: two positive"),
        (edit("polygon: [[-1, -1], [-0.5, -1], ", "polygon: ["),
         "places.bin.polygon: at least three"),
        (edit("{shape: box, size", "{shape: ball, size"), "classes.mug.shape: one of box"),
        (edit("size: [0.06, 0.06, 0.06]", "size: [0.06, 0.06]"),
         "classes.mug.size: a list of 3 numbers"),
        (edit("pose: [2.0, 0.0, 0.35, 0.0]", "pose: [2.0, 0.0]"),
         "furniture.bench.pose: a list of 4 numbers"),
        (edit("  tidy: {goal", "  Tidy Up: {goal"), "tasks.Tidy Up: 'Tidy Up' is not a name"),
        (edit("frame: map\n", "frame: /map\n"), "frame: a frame id"),
        (edit("frame: map\n", "frames: map\n"), "the site.frames: unknown key"),
        ("frame: map\n", "the site.places: missing"),
        ("places: [\n", ": not valid YAML"),
        ("- 1\n", "the site: a mapping"),
        (edit("  spoon: {class: mug}\n", "  bench: {class: mug}\n"),
         "'bench' names a place and an object"),
    ],
)  # fmt: skip
def test_a_bad_site_names_the_file_and_the_key(tmp_path: Path, text: str, key: str) -> None:
    f = write(tmp_path, text)
    with pytest.raises(SiteError) as e:
        load(f)
    message = str(e.value)
    assert message.startswith(f"{f}: ") and "\n" not in message
    assert key in message, message


def test_an_unreadable_site() -> None:
    with pytest.raises(SiteError, match=r"no-such\.yaml: no such site file"):
        load("no-such.yaml")
    with pytest.raises(SiteError, match="places: at least one place"):
        parse({"places": {}})


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO / "src"), os.environ.get("PYTHONPATH", "")]),
    }
    return subprocess.run(
        [sys.executable, "-m", "llmpas.cli", *args], cwd=cwd, env=env, capture_output=True,
        text=True, timeout=120,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("change", "task", "key"),
    [
        (("place: bench, at", 'place: "", at'), "tidy", "objects.mug.place: a non-empty string"),
        (("(On mug bin)", "(On mug shelf)"), "tidy", "tasks.tidy.goal: unknown place or object"),
        (("    reach: [[1.3, 0.0, 0.0]]\n", ""), "tidy", "places.bench.reach: no base pose"),
        (("x", "x"), "sweep", "no task 'sweep' in the site"),
    ],
)
def test_llmpas_run_with_a_bad_site_is_one_line(
    tmp_path: Path, change: tuple[str, str], task: str, key: str
) -> None:
    f = write(tmp_path, GOOD.replace(*change))
    out = run_cli("run", task, "--world", "ros2", "--robot-profile", "pybullet-standard",
                  "--site", str(f), "--no-llm", cwd=tmp_path)  # fmt: skip
    assert out.returncode not in (0, None), out
    assert "Traceback" not in out.stderr + out.stdout
    lines = [line for line in (out.stderr + out.stdout).splitlines() if line.strip()]
    assert len(lines) == 1, lines
    assert str(f.name) in lines[0] and key in lines[0], lines


def test_a_site_needs_a_standard_robot_and_the_ros2_world(tmp_path: Path) -> None:
    f = write(tmp_path, GOOD)
    out = run_cli("run", "tidy", "--robot-profile", "pybullet", "--site", str(f), "--no-llm",
                  cwd=tmp_path)  # fmt: skip
    assert out.returncode == 1 and "Traceback" not in out.stderr
    assert "a site is for a standard robot (interfaces: standard)" in out.stderr, out.stderr
    out = run_cli("run", "tidy", "--world", "pybullet", "--site", str(f), "--no-llm",
                  cwd=tmp_path)  # fmt: skip
    assert out.returncode != 0 and "--site: only --world ros2 reads a site file" in out.stderr
