"""``llmpas bench pddlstream``: scripts of our own (never PDDLStream's files), over seeds, with
llmpas alone and beside a stand-in "PDDLStream" checkout of our own (its plumbing only)."""

from __future__ import annotations

import io
import shutil
import textwrap
from pathlib import Path

import pytest
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments.benchmarks import benchmark
from llmpas.experiments.pddlstream_bench import (
    Instance,
    PdsBenchConfig,
    find_instances,
    run_bench,
)

SCRIPTS = Path(__file__).parents[1] / "pddlstream" / "scripts"

#: A script in PDDLStream's API: its goal names 4, an init value; a stream adds one. It prints
#: the seed's first draw, so the test sees that each planner got the seed.
POINTS = '''
import random
from pddlstream.algorithms.meta import solve
from pddlstream.language.constants import PDDLProblem, print_solution
from pddlstream.language.generator import from_fn

DOMAIN = """
(define (domain points)
  (:requirements :strips)
  (:predicates (Point ?p) (Next ?p ?q) (At ?p))
  (:action step :parameters (?p ?q)
    :precondition (and (At ?p) (Next ?p ?q))
    :effect (and (At ?q) (not (At ?p)))))
"""
STREAMS = """
(define (stream points)
  (:stream successor :inputs (?p) :domain (Point ?p) :outputs (?q)
    :certified (and (Point ?q) (Next ?p ?q))))
"""

if __name__ == "__main__":
    print("draw", random.random())
    init = [("Point", 2), ("At", 2), ("Point", 4)]
    problem = PDDLProblem(DOMAIN, {}, STREAMS, {"successor": from_fn(lambda p: (p + 1,))},
                          init, ("At", 4))
    print_solution(solve(problem, algorithm="incremental", max_time=30))
'''

#: A stand-in for a PDDLStream checkout (only what POINTS imports): it "plans" nothing, it
#: prints a solution as PDDLStream's print_solution does, so the side-by-side plumbing
#: (interpreter, PYTHONPATH, seed, parsing, ratio) is what is tested.
FAKE = {
    "pddlstream/__init__.py": "",
    "pddlstream/algorithms/__init__.py": "",
    "pddlstream/algorithms/meta.py": "def solve(problem, **kw):\n"
    "    return [('step', (2, 3)), ('step', (3, 4))], 2.0, []\n",
    "pddlstream/language/__init__.py": "",
    "pddlstream/language/generator.py": "def from_fn(fn):\n    return fn\n",
    "pddlstream/language/constants.py": textwrap.dedent(
        """
        from collections import namedtuple
        PDDLProblem = namedtuple("PDDLProblem", "domain constants streams map init goal")
        def print_solution(solution):
            plan, cost, _ = solution
            print("Solved: True")
            print("Cost: {:.3f}".format(cost))
            print("Length: {}".format(len(plan)))
        """
    ),
}


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def test_llmpas_alone_over_seeds_solves_and_validates(tmp_path: Path) -> None:
    folder = tmp_path / "examples"
    shutil.copytree(SCRIPTS, folder)
    config = PdsBenchConfig(
        folder, (Instance("tamp2d.py"),), seeds=2, timeout=120, out_dir=tmp_path / "out"
    )
    report = run_bench(config, quiet())
    assert [(t.planner, t.seed) for t in report.trials] == [("llmpas", 0), ("llmpas", 1)]
    assert all(t.solved and t.validated and t.status == "ok" for t in report.trials)
    assert all(t.length and t.length >= 4 and t.cpu > 0 for t in report.trials)
    (row,) = report.rows
    assert (row.solved, row.validated, row.trials) == (2, 2, 2)
    table = (tmp_path / "out" / "pddlstream.md").read_text()
    assert "| `tamp2d.py` | llmpas | 2/2 | 2/2 |" in table
    assert (tmp_path / "out" / "pddlstream.png").stat().st_size > 0
    assert (tmp_path / "out" / "pddlstream.csv").read_text().count("\n") == 3
    again = run_bench(config, quiet())  # cached: resumes without running anything again
    assert again.trials == report.trials


def test_side_by_side_runs_the_other_checkout_with_the_same_seed(tmp_path: Path) -> None:
    folder, root = tmp_path / "scripts", tmp_path / "checkout"
    folder.mkdir()
    (folder / "points.py").write_text(POINTS)
    for rel, text in FAKE.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    assert find_instances(folder) == (Instance("points.py"),)
    config = PdsBenchConfig(folder, seeds=1, timeout=120, pddlstream=root, out_dir=tmp_path / "o")
    report = run_bench(config, quiet())
    by = {t.planner: t for t in report.trials}
    assert by["llmpas"].solved and by["llmpas"].validated and by["llmpas"].length == 2
    assert by["pddlstream"].solved and by["pddlstream"].validated is None
    assert (by["pddlstream"].length, by["pddlstream"].cost) == (2, 2.0)
    table = (tmp_path / "o" / "pddlstream.md").read_text()
    ratio = by["llmpas"].cpu / by["pddlstream"].cpu
    assert f"| {ratio:.2f} |" in table
    assert "| `points.py` | pddlstream | 1/1 | - |" in table


def test_a_run_past_its_timeout_is_killed_and_unsolved(tmp_path: Path) -> None:
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "run.py").write_text(
        "import time\nimport pddlstream\nif __name__ == '__main__':\n    time.sleep(60)\n"
    )
    report = run_bench(PdsBenchConfig(folder, seeds=1, timeout=2, out_dir=tmp_path / "o"), quiet())
    (trial,) = report.trials
    assert (trial.status, trial.solved) == ("timeout", False)
    assert trial.wall < 30


def test_bad_options_are_one_line_errors(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert benchmark("pddlstream").name == "pddlstream"
    assert main(["bench", "pddlstream", str(tmp_path / "nowhere")]) == 2
    assert "no such folder" in capsys.readouterr().err
    assert main(["bench", "pddlstream", str(tmp_path), "--pddlstream", str(tmp_path)]) == 2
    assert "no pddlstream package there" in capsys.readouterr().err
    assert main(["bench", "pddlstream", str(tmp_path), "--instance", "x.py -n 4"]) == 2
    assert "no such script" in capsys.readouterr().err


def test_a_script_runs_from_the_top_of_its_package(tmp_path: Path) -> None:
    """As PDDLStream's examples/pybullet/ beside the pybullet module: a package in DIR named
    as an installed module does not shadow it (the run starts above DIR's package)."""
    examples = tmp_path / "examples"
    for pkg in ("", "numpy", "demo"):
        (examples / pkg).mkdir(parents=True, exist_ok=True)
        (examples / pkg / "__init__.py").write_text("")
    (examples / "numpy" / "__init__.py").write_text("raise ImportError('shadowed')\n")
    (examples / "demo" / "run.py").write_text(POINTS)
    config = PdsBenchConfig(examples, seeds=1, timeout=120, out_dir=tmp_path / "o")
    (trial,) = run_bench(config, quiet()).trials
    assert trial.instance == "demo/run.py"
    assert trial.solved and trial.validated, trial.note
