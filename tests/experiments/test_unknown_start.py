"""The validator accepts a task whose object's whereabouts are unknown at the start (issue #35,
item 6): `llmpas run` asks where to look and finishes it, and `bench validate-data` and the
suite's judge now agree (before: "unreachable: no plan from the believed initial state", and
the judge's verdict "no-anomaly"). The task file is the test's own
(tests/data/sight/unknown-start/)."""

from __future__ import annotations

from pathlib import Path

from llmpas.experiments.suite import Verdict, judge, load_task, validate_folder
from llmpas.experiments.worlds import LoopConfig
from llmpas.system.catalog import oracle_for
from tests.test_system import clean_blackboard  # noqa: F401 (autouse)

FOLDER = Path(__file__).parents[1] / "data" / "sight" / "unknown-start"


def test_validate_data_accepts_a_task_whose_object_is_nowhere_the_robot_knows() -> None:
    result = validate_folder(FOLDER, hash_seeds=())
    assert result.ok, [str(i) for i in result.issues]


def test_the_judge_counts_the_search_as_the_first_anomaly() -> None:
    task = load_task(FOLDER / "mug-somewhere.toml")
    judged = judge(task, oracle_for("household"), LoopConfig())
    assert judged.verdict is Verdict.SUCCESS, judged.message
    assert judged.anomaly == "(on mug ?)"
    assert judged.resolution_length == task.l_gt  # the search, the pick, the place
    assert judged.goals == ("(scanned table2_right)",)
