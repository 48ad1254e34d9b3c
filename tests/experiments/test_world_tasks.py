"""``bench prompting --world``: a world's shipped scenarios as the experiment's tasks
(:mod:`llmpas.experiments.world_tasks`), judged from the loop's own result; here on a user's world
(``package.module:WORLD``: the in-memory library of ``tests/worlds/test_protocol.py``, its oracle
beside it in this module), one with a truth judge and one without."""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from llmpas.errors import UsageError
from llmpas.experiments.prompting import PromptingConfig, run_prompting
from llmpas.experiments.prompting_tables import categories
from llmpas.experiments.suite import Verdict
from llmpas.experiments.world_tasks import verdict, world_tasks
from llmpas.language.logic import Atom, Not
from llmpas.reasoning.truth_oracle import TruthOracle
from llmpas.system import LoopResult
from llmpas.worlds.api import RunOptions
from tests.worlds.test_protocol import Library, LibrarySession

QUIET = Console(file=open("/dev/null", "w"))  # noqa: SIM115
HERE = "tests.experiments.test_world_tasks"


class NoTruthSession(LibrarySession):
    """The library seen by a robot with no ground truth: nothing judges the task afterwards."""

    def achieved(self) -> None:  # type: ignore[override]
        return None


class NoTruthLibrary(Library):
    @contextmanager
    def open(self, scenario: Any, options: RunOptions) -> Iterator[LibrarySession]:
        if scenario not in self.scenarios():
            raise KeyError(scenario)
        yield NoTruthSession(scenario.removeprefix("atlas-on-"))


WORLD = Library()
BLIND = NoTruthLibrary()


class LibraryOracle(TruthOracle):
    def __init__(self, session: LibrarySession) -> None:
        self.session = session

    def goals_for(self, atom: Atom, negated: bool) -> list[Atom | Not]:
        if atom.predicate == "in" and not negated:
            return [Atom("inspected", (self.session.truth[atom.args[0]],))]
        return []


def oracle(session: LibrarySession) -> LibraryOracle:
    return LibraryOracle(session)


@pytest.mark.parametrize(
    ("anomaly", "believed", "truth", "success", "expected"),
    [
        (False, True, True, True, Verdict.NO_ANOMALY),
        (True, False, None, False, Verdict.NOT_DONE),
        (True, True, False, False, Verdict.FALSE_DONE),  # believed done, truly not
        (True, True, True, True, Verdict.SUCCESS),
        (True, True, None, True, Verdict.SUCCESS),  # no truth: what was perceived decides
        (True, True, None, False, Verdict.FALSE_DONE),
    ],
)
def test_the_verdict_is_the_loops_against_the_truth(
    anomaly: bool, believed: bool, truth: bool | None, success: bool, expected: Verdict
) -> None:
    result = LoopResult("s", success, (), believed=believed, truth=truth)
    assert verdict(result, anomaly) is expected


def test_a_worlds_scenarios_are_its_tasks() -> None:
    tasks = world_tasks(f"{HERE}:WORLD")
    assert [t.name for t in tasks] == ["atlas-on-shelf1", "atlas-on-shelf2", "atlas-on-shelf3"]
    assert {t.category for t in tasks} == {"library"} and {t.l_gt for t in tasks} == {None}
    assert [t.name for t in world_tasks(f"{HERE}:WORLD", ["atlas-on-shelf3"])] == [
        "atlas-on-shelf3"
    ]
    with pytest.raises(UsageError, match=r"--tasks: no scenario 'nope' in .*known: atlas-on"):
        world_tasks(f"{HERE}:WORLD", ["nope"])
    with pytest.raises(UsageError, match="--world 'nosuch': expected one of household"):
        world_tasks("nosuch")


def test_the_suites_own_options_are_the_suites() -> None:
    for bad in ({"half": "development"}, {"measures_llm": True}, {"suite": Path("elsewhere")}):
        with pytest.raises(ValueError, match="the household suite's option; --world library"):
            PromptingConfig(world="library", **bad)  # type: ignore[arg-type]


def test_categories_keep_the_suites_order_then_the_worlds() -> None:
    found = categories(["library", "state-change", "all", "object-loss", "library"])
    titles = [("object-loss", "Object Loss"), ("state-change", "State Change")]
    assert found == [*titles, ("library", "library")]


def _run(
    tmp_path: Path, world: str, keep: bool = False
) -> tuple[dict[tuple[str, str], dict[str, Any]], str]:
    config = PromptingConfig(
        llm="oracle",
        methods=(),
        samples=1,
        world=world,
        out_dir=tmp_path,
        max_time=30.0,
        keep_runs=keep,
    )
    report = run_prompting(config, QUIET)
    samples = {(str(r["method"]), str(r["task"])): r for r in report.records}
    return samples, (tmp_path / "prompting.md").read_text()


def test_the_oracle_and_replan_rows_run_a_users_world(tmp_path: Path) -> None:
    samples, table = _run(tmp_path, f"{HERE}:WORLD", keep=True)
    verdicts = {k: r["verdict"] for k, r in samples.items()}
    assert verdicts[("oracle", "atlas-on-shelf2")] == "success"
    assert verdicts[("replan", "atlas-on-shelf2")] == "not-done"
    assert verdicts[("oracle", "atlas-on-shelf1")] == "no-anomaly"
    found = samples[("oracle", "atlas-on-shelf3")]
    assert found["basis"] == "truth" and found["l_gt"] is None and found["category"] == "library"
    assert found["anomaly"] == "(in atlas shelf1)" and found["resolution_length"] == 3
    assert table.startswith(f"Prompting methods on the {HERE}:WORLD scenarios")
    assert "| oracle (upper bound) | 0.67 | — | — |" in table
    assert "judged on what the robot perceived" not in table
    kept = sorted((tmp_path / "runs").glob("*/about.json"))  # one folder per sample
    assert len(kept) == 6 and all(p.with_name("loop.json").is_file() for p in kept)
    about = json.loads(kept[0].read_text())
    assert about["world"] == f"{HERE}:WORLD" and about["task"] == "(and (delivered atlas))"


def test_a_world_without_truth_is_judged_on_what_was_perceived(tmp_path: Path) -> None:
    samples, table = _run(tmp_path, f"{HERE}:BLIND")
    assert {r["basis"] for r in samples.values()} == {"perceived"}
    assert samples[("oracle", "atlas-on-shelf3")]["verdict"] == "success"
    assert "6 samples were judged on what the robot perceived" in table
