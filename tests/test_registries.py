"""The extension points as registries (#25 item 5): adding a planning algorithm, a classical
planner, a prompting method or a benchmark is one new file plus one registry line.

Each test below writes the new file into a temporary folder on ``sys.path`` (or next to the
templates it names), adds the one line to the registry (the mapping with one more entry), and
sees the new choice in the command line's options and running there."""

from __future__ import annotations

import argparse
import json
import textwrap
from pathlib import Path
from types import MappingProxyType

import pytest

from llmpas.cli import build_parser, main
from llmpas.planning import PlannerConfig, planner_registry, solve
from llmpas.planning.planner_registry import Entry


def _write_module(folder: Path, name: str, text: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The one new file: a module ``name`` in ``folder``, importable from now on."""
    (folder / f"{name}.py").write_text(textwrap.dedent(text), encoding="utf-8")
    monkeypatch.syspath_prepend(str(folder))


def _parser(argv: list[str]) -> argparse.ArgumentParser:
    """The parser of the subcommand ``argv`` (e.g. ``["bench", "tamp"]``)."""
    parser = build_parser()
    for word in argv:
        parser = _subparsers(parser).choices[word]
    return parser


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:  # type: ignore[type-arg]
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def _choices(argv: list[str], option: str) -> tuple[str, ...]:
    """The choices the parser offers for ``option`` of the subcommand ``argv``."""
    action = next(a for a in _parser(argv)._actions if option in a.option_strings)
    return tuple(action.choices or ())


# ------------------------------------------------------------------- planning algorithms


ALGORITHM = '''
    """A planning algorithm: incremental planning under another name (the example of adding one)."""

    from llmpas.planning.result import PlanResult
    from llmpas.planning.planner_run import Run
    from llmpas.planning.tamp import plan_incremental


    def plan(run: Run) -> PlanResult:
        return plan_incremental(run)
'''


def test_a_new_algorithm_is_one_file_and_one_registry_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _write_module(tmp_path, "levels_example", ALGORITHM, monkeypatch)
    line = Entry("levels", "levels_example:plan", "incremental, under another name")
    table = MappingProxyType({**planner_registry.ALGORITHMS, "levels": line})
    monkeypatch.setattr(planner_registry, "ALGORITHMS", table)

    assert "levels" in _choices(["plan"], "--algorithm")
    assert "levels" in _choices(["bench", "planning-time"], "--algorithm")
    argv = ["plan", "--example", "tamp2d", "--size", "2", "--algorithm", "levels", "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "solved" and out["stats"]["algorithm"] == "levels"


def test_an_unregistered_algorithm_is_a_one_line_usage_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert "levels" not in planner_registry.algorithm_names()
    with pytest.raises(ValueError, match="unknown algorithm 'levels'; choose one of focused"):
        PlannerConfig(algorithm="levels")
    assert main(["plan", "--example", "tamp2d", "--algorithm", "levels"]) == 2
    assert "invalid choice: 'levels'" in capsys.readouterr().err


# --------------------------------------------------------------------- classical planners


CLASSICAL = '''
    """A classical planner that finds nothing (the example of adding one)."""

    from llmpas.planning.config import PlannerConfig
    from llmpas.planning.downward import ClassicalPlan, ClassicalStatus


    class Refuses:
        def solve(self, domain: str, task: str, *, max_time: float | None = None) -> ClassicalPlan:
            return ClassicalPlan(ClassicalStatus.UNSOLVABLE, (), None, 0.0, 0.0, "refused")


    def make(search: str, config: PlannerConfig) -> Refuses:
        return Refuses()
'''


def test_a_new_classical_planner_is_one_file_and_one_registry_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _write_module(tmp_path, "refuses_example", CLASSICAL, monkeypatch)
    line = Entry("refuses", "refuses_example:make", "finds no plan")
    table = MappingProxyType({**planner_registry.CLASSICAL_PLANNERS, "refuses": line})
    monkeypatch.setattr(planner_registry, "CLASSICAL_PLANNERS", table)

    assert _choices(["plan"], "--classical") == ("fast-downward", "refuses")
    argv = ["plan", "--example", "tamp2d", "--size", "2", "--json"]
    assert main(argv) == 0  # Fast Downward by default
    assert json.loads(capsys.readouterr().out)["status"] == "solved"
    assert main([*argv, "--classical", "refuses"]) == 1  # every search on the new planner
    assert json.loads(capsys.readouterr().out)["status"] == "unsolvable"


def test_the_classical_planner_is_chosen_by_the_config() -> None:
    from llmpas.examples import get_example

    problem = get_example("tamp2d").make_problem(2, 0)
    with pytest.raises(ValueError, match="unknown classical planner 'refuses'"):
        PlannerConfig(classical="refuses")
    assert solve(problem, PlannerConfig(classical="fast-downward")).solved


# ---------------------------------------------------------------------- prompting methods


TEMPLATE = """\
## Predicates
$predicates

## Anomaly (asked by the example method 'terse')
$anomaly
$history
Answer with one line: Goals: $example
"""


def test_a_new_prompting_method_is_one_file_and_one_registry_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from llmpas.experiments.prompting import PromptingConfig
    from llmpas.reasoning import methods
    from llmpas.reasoning.methods import Method, MethodConfig

    (tmp_path / "terse.txt").write_text(TEMPLATE, encoding="utf-8")  # the one new file
    line = Method("terse", str(tmp_path / "terse.txt"))
    monkeypatch.setattr(methods, "REGISTRY", MappingProxyType({**methods.REGISTRY, "terse": line}))

    assert "terse" in _choices(["run"], "--method")
    assert PromptingConfig(methods=("terse",)).methods == ("terse",)  # bench prompting --methods
    assert MethodConfig("terse").method == "terse"
    out = tmp_path / "run"
    # the closed loop asks with the new template (the replan backend restates the task: not done)
    argv = ["run", "object-loss-table", "--llm", "replan", "--method", "terse", "--rounds", "1"]
    assert main([*argv, "--out", str(out)]) == 1
    assert "asked by the example method 'terse'" in (out / "loop.md").read_text(encoding="utf-8")


def test_an_unregistered_method_is_a_one_line_error(capsys: pytest.CaptureFixture[str]) -> None:
    from llmpas.reasoning.methods import MethodConfig

    with pytest.raises(ValueError, match=r"method must be one of flp, .*; got 'terse'"):
        MethodConfig("terse")
    assert main(["run", "object-loss-table", "--llm", "replan", "--method", "terse"]) == 2
    assert "invalid choice: 'terse'" in capsys.readouterr().err


# ---------------------------------------------------------------------------- benchmarks


BENCHMARK = '''
    """A benchmark: counts the shipped examples (the example of adding one)."""

    import argparse
    from pathlib import Path

    from rich.console import Console

    from llmpas.examples import EXAMPLES
    from llmpas.experiments.benchmarks import AllConfig
    from llmpas.files import atomic_write


    class Examples:
        name = "examples"
        help = "how many shipped examples there are"

        def add_arguments(self, parser: argparse.ArgumentParser) -> None:
            parser.add_argument("--out", default="results/examples")

        def command(self, args: argparse.Namespace, console: Console) -> int:
            Path(args.out).mkdir(parents=True, exist_ok=True)
            atomic_write(Path(args.out) / "examples.md", f"| examples |\\n| {len(EXAMPLES)} |\\n")
            return 0

        def step(self, config: AllConfig) -> tuple[str, ...] | None:
            return ("--out", str(config.out_dir / self.name))


    BENCHMARK = Examples()
'''


def test_a_new_benchmark_is_one_file_and_one_registry_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from llmpas.examples import EXAMPLES
    from llmpas.experiments import benchmarks
    from llmpas.experiments.everything import AllConfig, plan_steps, run_all

    _write_module(tmp_path, "examples_bench", BENCHMARK, monkeypatch)
    table = MappingProxyType({**benchmarks.BENCHMARKS, "examples": "examples_bench:BENCHMARK"})
    monkeypatch.setattr(benchmarks, "BENCHMARKS", table)

    assert list(_subparsers(_parser(["bench"])).choices)[-2:] == ["examples", "all"]
    assert isinstance(benchmarks.benchmark("examples"), benchmarks.Benchmark)

    out = tmp_path / "out"
    assert main(["bench", "examples", "--out", str(out)]) == 0
    assert (out / "examples.md").read_text() == f"| examples |\n| {len(EXAMPLES)} |\n"
    assert main(["bench", "examples", "--out", "/dev/null/x"]) == 6  # the CLI's own checks
    assert capsys.readouterr().err.strip() == "error: --out /dev/null/x: /dev/null is not a folder"

    # `bench all` runs it after the others, as its own command, into its own folder
    config = AllConfig(llm="oracle", out_dir=tmp_path / "all")
    steps = plan_steps(config)
    assert steps[-1].argv == ("bench", "examples", "--out", str(tmp_path / "all" / "examples"))
    ran: list[str] = []

    def run(argv: list[str]) -> int:  # the new step for real, the others only recorded
        ran.append(argv[1])
        return main(list(argv)) if argv[1] == "examples" else 0

    outcomes = run_all(config, run)  # type: ignore[arg-type]
    assert ran[-1] == "examples" and outcomes[-1].status == 0
    assert "| examples | ok |" in (tmp_path / "all" / "summary.md").read_text()


def test_the_bench_subcommands_are_the_registry() -> None:
    from llmpas.experiments.benchmarks import benchmark, benchmark_names, benchmarks

    assert [b.name for b in benchmarks()] == list(benchmark_names())
    assert list(_subparsers(_parser(["bench"])).choices) == [*benchmark_names(), "all"]
    with pytest.raises(ValueError, match="unknown benchmark 'nope'; choose one of validate-data"):
        benchmark("nope")


# ------------------------------------------------------------------------------- the docs


def _readme_row(extension: str) -> tuple[str, ...]:
    readme = (Path(__file__).parents[1] / "README.md").read_text(encoding="utf-8")
    row = next(line for line in readme.splitlines() if line.startswith(f"| {extension} "))
    return tuple(name.strip(" `") for name in row.split(" | ")[2].split(","))


def test_the_readme_lists_what_each_registry_holds() -> None:
    from llmpas.experiments.benchmarks import benchmark_names
    from llmpas.reasoning.methods import method_names
    from llmpas.system.catalog import worlds

    assert _readme_row("planning algorithm") == planner_registry.algorithm_names()
    assert _readme_row("classical planner") == planner_registry.classical_names()
    assert _readme_row("prompting method") == method_names()
    assert _readme_row("benchmark") == benchmark_names()
    assert _readme_row("world") == tuple(worlds())
