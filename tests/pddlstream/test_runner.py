"""``llmpas pddlstream SCRIPT``: unchanged scripts run on this API, never over a real install."""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

from llmpas.cli import main

SCRIPTS = Path(__file__).parent / "scripts"


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text))
    return path


def test_runs_a_script_and_validates_its_plan(tmp_path, capsys) -> None:
    summary = tmp_path / "s.json"
    code = main(["pddlstream", "--summary", str(summary), str(SCRIPTS / "blocks_streams.py")])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "Solved: True" in out and "replay: valid" in out
    (solve,) = json.loads(summary.read_text())["solves"]
    assert solve["status"] == "solved" and solve["valid"] and solve["length"] >= 4
    assert not any(m.split(".")[0] == "pddlstream" for m in sys.modules)


def test_script_args_reach_the_script(capsys) -> None:
    assert main(["pddlstream", str(SCRIPTS / "costs_exists.py"), "-u"]) == 0
    out = capsys.readouterr().out
    length = int(out.split("Length: ")[1].split()[0])
    assert f"Cost: {length:.3f}" in out  # unit costs: the cost is the length


def test_a_script_in_a_package_imports_its_siblings(tmp_path, capsys) -> None:
    root = tmp_path / "repo"
    write(root / "examples" / "__init__.py", "")
    write(root / "examples" / "demo" / "__init__.py", "")
    write(
        root / "examples" / "demo" / "helpers.py",
        """
        def double(x):
            return (2 * x,)
    """,
    )
    script = write(
        root / "examples" / "demo" / "run.py",
        """
        from examples.demo.helpers import double
        from pddlstream.algorithms.meta import solve
        from pddlstream.language.constants import PDDLProblem, print_solution
        from pddlstream.language.generator import from_fn
        DOMAIN = '''(define (domain d) (:predicates (N ?x) (Big ?x) (Done))
          (:action go :parameters (?x) :precondition (Big ?x) :effect (Done)))'''
        STREAM = '''(define (stream d) (:stream double :inputs (?x) :domain (N ?x)
          :outputs (?y) :certified (Big ?y)))'''
        if __name__ == "__main__":
            print_solution(solve(PDDLProblem(DOMAIN, {}, STREAM, {"double": from_fn(double)},
                                             [("N", 21)], ("Done",)), max_time=30))
    """,
    )
    assert main(["pddlstream", str(script)]) == 0
    assert "go 42" in capsys.readouterr().out


def test_never_shadows_a_real_pddlstream(tmp_path, capsys) -> None:
    marker = tmp_path / "imported"
    write(tmp_path / "pddlstream" / "__init__.py", f"open({str(marker)!r}, 'w').close()\n")
    script = write(tmp_path / "run.py", "from pddlstream.algorithms.meta import solve\n")
    assert main(["pddlstream", str(script)]) == 2
    err = capsys.readouterr().err
    assert "real PDDLStream" in err and str(tmp_path / "pddlstream") in err
    assert len(err.strip().splitlines()) == 1
    assert not marker.exists()  # found, not imported
    assert "pddlstream" not in sys.modules


def test_refusals_and_failures_are_one_line(tmp_path, capsys) -> None:
    cases = {
        "from pddlstream.language.exogenous import FutureValue\n": (3, "not part of"),
        "from pddlstream.algorithms.meta import solve\n"
        "from pddlstream.language.constants import PDDLProblem\n"
        "solve(PDDLProblem('(define (domain d))', {}, None, {}, [], ('P',)), algorithm='x')\n": (
            3,
            "algorithm 'x' does not exist",
        ),
        "import pddlstream.utils\nraise RuntimeError('boom')\n": (
            1,
            "bad.py:2: RuntimeError: boom",
        ),
    }
    for text, (code, words) in cases.items():
        script = write(tmp_path / "bad.py", text)
        assert main(["pddlstream", str(script)]) == code
        err = capsys.readouterr().err.strip()
        assert words in err and len(err.splitlines()) == 1 and "Traceback" not in err


def test_a_script_on_debug_streams_that_sets_pddlstreams_switches(tmp_path, capsys) -> None:
    """The shape of PDDLStream's kitchen example: it sets switches of PDDLStream's own
    implementation, reads its files with ``read_pddlstream_pair`` and plans with debug
    streams (every stream's outputs are placeholders; tests pass; costs are 0)."""
    write(
        tmp_path / "domain.pddl",
        """
        (define (domain cups)
          (:requirements :strips)
          (:predicates (Cup ?c) (Pose ?c ?p) (At ?c ?p) (Free ?c ?p) (Moved ?c))
          (:functions (Effort ?c))
          (:action move :parameters (?c ?p1 ?p2)
            :precondition (and (Pose ?c ?p2) (At ?c ?p1) (Free ?c ?p2))
            :effect (and (At ?c ?p2) (not (At ?c ?p1)) (Moved ?c)
                         (increase (total-cost) (Effort ?c)))))
        """,
    )
    write(
        tmp_path / "stream.pddl",
        """
        (define (stream cups)
          (:stream sample-pose :inputs (?c) :domain (Cup ?c) :outputs (?p)
            :certified (Pose ?c ?p))
          (:stream test-free :inputs (?c ?p) :domain (Pose ?c ?p) :certified (Free ?c ?p))
          (:function (Effort ?c) (Cup ?c)))
        """,
    )
    mode = "SHARED_DEBUG"
    script = write(
        tmp_path / "run.py",
        f"""
        from pddlstream.algorithms import instantiate_task
        instantiate_task.FD_INSTANTIATE = True
        from pddlstream.algorithms import instantiation
        instantiation.USE_RELATION = True
        from pddlstream.algorithms import refinement
        refinement.CONSTRAIN_PLANS = False
        from pddlstream.algorithms.meta import solve
        from pddlstream.language.constants import And, PDDLProblem, read_pddlstream_pair
        from pddlstream.language.stream import DEBUG, SHARED_DEBUG

        domain_pddl, stream_pddl = read_pddlstream_pair(__file__)
        init = [('Cup', 'c1'), ('Cup', 'c2'), ('At', 'c1', 1), ('At', 'c2', 2)]
        goal = And(('Moved', 'c1'), ('Moved', 'c2'))
        problem = PDDLProblem(domain_pddl, {{}}, stream_pddl, {mode}, init, goal)
        plan, cost, _ = solve(problem, max_time=60)
        assert [a.name for a in plan] == ['move', 'move'] and cost == 0, (plan, cost)
        print('values', sorted(repr(a.args[2]) for a in plan))
        """,
    )
    summary = tmp_path / "s.json"
    assert main(["pddlstream", "--summary", str(summary), str(script)]) == 0
    out = capsys.readouterr().out
    (solve,) = json.loads(summary.read_text())["solves"]
    assert solve["valid"], solve
    assert "values ['&p', '&p']" in out  # shared: one value per stream and output
    script.write_text(script.read_text().replace(mode, "DEBUG"))
    assert main(["pddlstream", "--summary", str(summary), str(script)]) == 0
    (solve,) = json.loads(summary.read_text())["solves"]
    assert solve["valid"], solve
    assert "values ['@p0', '@p1']" in capsys.readouterr().out  # a new value per call
