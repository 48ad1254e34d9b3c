"""A new shipped world is one folder (docs/worlds.md, "Add a shipped world"): a package under
``llmpas/worlds/`` whose ``__init__.py`` registers it (``WORLD_ENTRY``), its world and its
oracle beside it. Built here in a copy of the source tree, with no other file touched, it is
found by name by the product's registry (:mod:`llmpas.system.catalog`), named in ``llmpas run``'s
help, and run by ``llmpas run`` with the two recovery methods that ask no model (``oracle``,
``replan``); ``llmpas run`` loads nothing of :mod:`llmpas.experiments`. ``llmpas bench prompting
--world library`` runs its scenarios as tasks with the same two rows and writes the table.

The world's code is the in-memory library of ``tests/worlds/test_protocol.py`` (books on
shelves, searched by ``(inspected SHELF)``), so the folder holds only what a world adds to be
shipped: its registration and its oracle."""

from __future__ import annotations

import csv
import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

INIT = '''"""The library: an atlas on one of three shelves (a world in one folder)."""

from llmpas.worlds.api import WorldEntry

WORLD_ENTRY = WorldEntry(
    "library",
    "llmpas.worlds.library.library_world:WORLD",
    oracle="llmpas.worlds.library.library_world:oracle",
    rank=50,
    help="atlas-on-shelf1..3 (a library in memory)",
)
'''

WORLD = '''"""The library world and its labelled oracle (it reads where the atlas truly is)."""

from llmpas.language.logic import Atom, Not
from llmpas.reasoning.truth_oracle import TruthOracle
from tests.worlds.test_protocol import Library, LibrarySession

WORLD = Library()


class LibraryOracle(TruthOracle):
    def __init__(self, session: LibrarySession) -> None:
        self.session = session

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        if atom.predicate == "in" and not negated:  # not where believed: look where it is
            return [Atom("inspected", (self.session.truth[atom.args[0]],))]
        return []


def oracle(session: LibrarySession) -> LibraryOracle:
    return LibraryOracle(session)
'''

CHECK = """
import sys
from llmpas.cli import main
code = main(sys.argv[1:])
loaded = sorted(m for m in sys.modules if m.startswith("llmpas.experiments"))
print("experiments loaded:", loaded)
sys.exit(code)
"""


@pytest.fixture(scope="module")
def tree(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the source tree with one new folder: ``llmpas/worlds/library/``."""
    src = tmp_path_factory.mktemp("tree") / "src"
    shutil.copytree(
        ROOT / "src" / "llmpas", src / "llmpas", ignore=shutil.ignore_patterns("__pycache__")
    )
    folder = src / "llmpas" / "worlds" / "library"
    folder.mkdir()
    (folder / "__init__.py").write_text(INIT)
    (folder / "library_world.py").write_text(WORLD)
    return src


BENCH = """
import sys
import llmpas.system.catalog as catalog
asked = []
load = catalog.load_world
def recorded(spec):
    asked.append(spec)
    return load(spec)
catalog.load_world = recorded  # before any module takes it: every world the run asked for
from llmpas.cli import main
code = main(sys.argv[1:])
print("worlds loaded:", sorted(set(asked)))
sys.exit(code)
"""


def llmpas(src: Path, *argv: str, script: str = CHECK) -> subprocess.CompletedProcess[str]:
    """``llmpas ARGV`` on the copied tree (the repository root on the path for ``tests``)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(src), str(ROOT)]), "COLUMNS": "200"}
    return subprocess.run(
        [sys.executable, "-c", script, *argv],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
        cwd=src.parent,
    )


def test_the_folder_is_the_whole_registration(tree: Path) -> None:
    found = llmpas(tree, "run", "--help")
    assert found.returncode == 0, found.stderr
    assert "household, pybullet, tabletop, library, or your own package.module:WORLD" in (
        " ".join(found.stdout.split())
    )
    assert "atlas-on-shelf1..3 (a library in memory)" in " ".join(found.stdout.split())
    wrong = llmpas(tree, "run", "atlas-on-shelf3", "--world", "nosuch")
    assert wrong.returncode == 2
    assert "expected one of household, pybullet, tabletop, ros2, library or" in wrong.stderr


def test_llmpas_run_runs_it_with_the_oracle_and_replan(tree: Path, tmp_path: Path) -> None:
    out = tmp_path / "oracle"
    run = llmpas(
        tree, "run", "atlas-on-shelf3", "--world", "library", "--llm", "oracle", "--out", str(out)
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "task done" in run.stdout and "(inspected shelf3)" in run.stdout
    assert "experiments loaded: []" in run.stdout  # llmpas run imports nothing of them
    assert (out / "loop.json").is_file() and (out / "library.json").is_file()
    replan = llmpas(tree, "run", "atlas-on-shelf3", "--world", "library", "--llm", "replan")
    assert replan.returncode == 1, replan.stdout + replan.stderr  # the task again: not found
    assert "not done" in replan.stdout and "experiments loaded: []" in replan.stdout


def test_a_shipped_scenario_name_finds_its_world(tree: Path) -> None:
    run = llmpas(tree, "run", "atlas-on-shelf2", "--llm", "oracle", "--rounds", "2")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "a library (in memory)" in run.stdout or "task done" in run.stdout


def files(src: Path) -> dict[str, str]:
    """Every file of the tree (bytecode caches left out) and its SHA-256."""
    return {
        str(p.relative_to(src)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(src.rglob("*"))
        if p.is_file() and "__pycache__" not in p.parts
    }


def test_bench_prompting_runs_its_scenarios(tree: Path, tmp_path: Path) -> None:
    """``bench prompting --world library``: the world's scenarios are the tasks, the oracle and
    replan rows run them, each judged from the loop's verdict and the world's truth; the run
    asks the registry for the folder's world only and writes nothing but its ``--out``."""
    before, out = files(tree), tmp_path / "bench"
    argv = ("bench", "prompting", "--world", "library", "--llm", "oracle", "--methods", "none")
    bench = llmpas(tree, *argv, "--samples", "1", "--out", str(out), script=BENCH)
    assert bench.returncode == 0, bench.stdout + bench.stderr
    assert "worlds loaded: ['library']" in bench.stdout
    assert files(tree) == before  # nothing else touched
    table = (out / "prompting.md").read_text()
    assert table.startswith("Prompting methods on the library scenarios (LLM: oracle;")
    assert "| Method | library SR | library ASPL | library 1st eff. |" in table
    assert "| oracle (upper bound) | 0.67 | — | — |" in table  # no l_gt: no ASPL
    assert "| replan (no reasoning: the task restated) | 0.00 | — | — |" in table
    with (out / "prompting_samples.csv").open() as f:
        samples = {(r["method"], r["task"]): r for r in csv.DictReader(f)}
    verdicts = {key: r["verdict"] for key, r in samples.items()}
    assert verdicts == {
        ("oracle", "atlas-on-shelf1"): "no-anomaly",  # where it is believed: nothing to resolve
        ("oracle", "atlas-on-shelf2"): "success",
        ("oracle", "atlas-on-shelf3"): "success",
        ("replan", "atlas-on-shelf1"): "no-anomaly",
        ("replan", "atlas-on-shelf2"): "not-done",  # the task again: the atlas is not found
        ("replan", "atlas-on-shelf3"): "not-done",
    }
    assert samples[("oracle", "atlas-on-shelf3")]["goals"] == "(inspected shelf3)"
    assert {(r["category"], r["basis"], r["l_gt"]) for r in samples.values()} == {
        ("library", "truth", "")
    }


def test_bench_prompting_names_a_bad_world(tree: Path, tmp_path: Path) -> None:
    wrong = llmpas(tree, "bench", "prompting", "--world", "nosuch", "--out", str(tmp_path))
    assert wrong.returncode == 2, wrong.stdout + wrong.stderr
    assert wrong.stderr.strip().splitlines() == [
        "error: --world 'nosuch': expected one of household, pybullet, tabletop, ros2, library "
        "or package.module:ATTR"
    ]


LISTING = """
import sys
from llmpas.system.catalog import robots, worlds
names = list(worlds()), list(robots())
heavy = sorted(m for m in sys.modules if m == "pybullet" or m.startswith("rclpy")
               or (m.startswith("llmpas.worlds.") and m.count(".") > 2))
print(names, heavy)
"""


def test_the_registry_reads_the_folders_without_loading_a_world() -> None:
    """Listing the worlds and robots imports each folder's ``__init__`` only: no world module
    (``llmpas.worlds.X.Y``; ``llmpas.worlds.api``, the protocol, is no world), no simulator."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    out = subprocess.run(
        [sys.executable, "-c", LISTING], capture_output=True, text=True, timeout=120, env=env
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == (
        "(['household', 'pybullet', 'tabletop', 'ros2'], ['pybullet']) []"
    ), out.stdout


def test_every_registration_names_modules_that_exist() -> None:
    """A registration names its modules as text (``module:ATTR``, imported when used): a
    module renamed or moved without its registration fails here, before a run does."""
    import importlib.util

    from llmpas.system.catalog import robots, worlds

    specs = [s for e in worlds().values() for s in (e.world, e.oracle, e.files) if s]
    specs += [r.command for r in robots().values()]
    missing = [s for s in specs if importlib.util.find_spec(s.partition(":")[0]) is None]
    assert specs and not missing, missing
