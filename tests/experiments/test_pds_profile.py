"""``llmpas bench pddlstream --profile``: where each planner's CPU goes (scripts of our own; the
PDDLStream side against a stand-in checkout of our own that calls its stream instances)."""

from __future__ import annotations

import cProfile
import io
import shutil
import textwrap
import time
from pathlib import Path

from rich.console import Console

from llmpas.experiments.pddlstream_bench import Instance, PdsBenchConfig, run_bench
from llmpas.experiments.pds_profile import Profile, entered

SCRIPTS = Path(__file__).parents[1] / "pddlstream" / "scripts"


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def _spin(seconds: float) -> None:
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def _inner() -> None:
    _spin(0.02)


def _outer() -> None:
    _inner()
    _inner()


def test_entered_counts_a_category_once_where_it_is_entered() -> None:
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    _outer()
    _outer()
    _inner()
    prof.disable()
    prof.create_stats()
    stats = prof.stats  # type: ignore[attr-defined]

    def named(*names: str):  # type: ignore[no-untyped-def]
        return lambda f: f[2] in names

    both_cpu, both_calls = entered(stats, named("_outer", "_inner"))
    assert both_calls == 3  # two _outer calls and the lone _inner, not the nested ones
    assert 0.09 < both_cpu < 0.2
    inner_cpu, inner_calls = entered(stats, named("_inner"))
    assert inner_calls == 5 and abs(inner_cpu - both_cpu) < 0.02
    from_outer = entered(stats, named("_inner"), named("_outer"))
    assert from_outer[1] == 4


def test_llmpas_profile_splits_its_solve_and_counts_streams(tmp_path: Path) -> None:
    folder = tmp_path / "examples"
    shutil.copytree(SCRIPTS, folder)
    config = PdsBenchConfig(
        folder, (Instance("tamp2d.py"),), seeds=1, timeout=120, out_dir=tmp_path / "out",
        profile=True,
    )  # fmt: skip
    report = run_bench(config, quiet())
    (trial,) = report.trials
    assert trial.solved and trial.validated
    rows = (tmp_path / "out" / "profile.csv").read_text().splitlines()
    assert len(rows) == 2 and rows[0].startswith("planner,instance,seed,solved,solve,")
    table = (tmp_path / "out" / "profile.md").read_text()
    assert "### `tamp2d.py`" in table and "| Fast Downward searches |" in table
    assert (tmp_path / "out" / "profile-tamp2d-py.png").stat().st_size > 0
    cache = next((tmp_path / "out" / "cache").rglob("*.json"))
    import json

    prof = Profile.from_dict(json.loads(cache.read_text())["result"]["profile"])
    assert prof.searches >= 1 and prof.translations == prof.searches
    assert prof.optimistic_plans >= 1 and prof.iterations >= prof.optimistic_plans
    assert prof.solve > 0 and prof.translation > 0 and prof.streams > 0
    parts = prof.instantiation + prof.translation + prof.search + prof.streams + prof.other
    assert abs(parts - prof.solve) < 0.05 * prof.solve + 0.01
    assert prof.per_stream and all(0 <= s.successes <= s.calls for s in prof.per_stream)
    assert abs(sum(s.cpu for s in prof.per_stream) - prof.streams) < 0.01 + 0.1 * prof.streams


#: A stand-in PDDLStream: its solve starts a profiler of its own (as PDDLStream's examples do),
#: calls one stream instance's next_results twice (one output, then none) and a "search" child
#: process, so the prelude's counts are what is tested.
FAKE = {
    "pddlstream/__init__.py": "",
    "pddlstream/algorithms/__init__.py": "",
    "pddlstream/language/__init__.py": "",
    "pddlstream/language/function.py": "class FunctionInstance:\n"
    "    def next_results(self, verbose=False):\n        return [], []\n",
    "pddlstream/language/stream.py": textwrap.dedent(
        """
        class Result:
            def is_successful(self):
                return True
        class External:
            name = "sample-thing"
        class StreamInstance:
            external = External()
            calls = 0
            def next_results(self, verbose=False):
                self.calls += 1
                return ([Result()] if self.calls == 1 else []), []
        """
    ),
    "pddlstream/algorithms/downward.py": textwrap.dedent(
        """
        import subprocess, sys
        def run_search():
            subprocess.run([sys.executable, "-c", "sum(range(3000000))"], check=True)
        """
    ),
    "pddlstream/algorithms/meta.py": textwrap.dedent(
        """
        import cProfile, pstats
        from pddlstream.language.stream import StreamInstance
        from pddlstream.algorithms.downward import run_search
        def solve(problem, **kw):
            own = cProfile.Profile()  # as PDDLStream's Profiler: must not end the bench's
            own.enable()
            own.disable()
            pstats.Stats(own).print_stats(3)
            inst = StreamInstance()
            inst.next_results()
            inst.next_results()
            run_search()
            print("Solved: True")
            print("Cost: 1.000")
            print("Length: 1")
        """
    ),
}


def test_pddlstream_side_is_profiled_from_outside(tmp_path: Path) -> None:
    folder, root = tmp_path / "scripts", tmp_path / "checkout"
    folder.mkdir()
    (folder / "one.py").write_text(
        "from pddlstream.algorithms.meta import solve\nif __name__ == '__main__':\n"
        "    solve(None)\n"
    )
    for rel, text in FAKE.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    config = PdsBenchConfig(
        folder, seeds=1, timeout=120, pddlstream=root, out_dir=tmp_path / "o", profile=True
    )
    report = run_bench(config, quiet())
    by = {t.planner: t for t in report.trials}
    assert by["pddlstream"].solved
    table = (tmp_path / "o" / "profile.md").read_text()
    assert "| sample-thing | pddlstream | 2 | 1 |" in table
    csv = (tmp_path / "o" / "profile.csv").read_text().splitlines()
    (line,) = [ln for ln in csv if ln.startswith("pddlstream,")]
    row = dict(zip(csv[0].split(","), line.split(","), strict=True))
    assert int(row["searches"]) == 1 and float(row["search"]) > 0.02
    assert float(row["solve"]) >= float(row["search"])


def _middle() -> None:
    _outer()


def _top() -> None:
    _middle()


def test_outermost_counts_a_nested_entry_point_once() -> None:
    from llmpas.experiments.pds_profile import outermost

    prof = cProfile.Profile(time.process_time)
    prof.enable()
    _top()
    prof.disable()
    prof.create_stats()
    stats = prof.stats  # type: ignore[attr-defined]
    match = lambda f: f[2] in ("_top", "_outer")  # noqa: E731 - _outer under _top via _middle
    assert entered(stats, match)[0] > 0.07  # summed: counted twice
    assert 0.03 < outermost(stats, match) < 0.06
