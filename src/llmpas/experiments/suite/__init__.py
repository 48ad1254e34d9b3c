"""The household anomaly suite: one TOML file per task, the judge that decides whether a run
resolved its anomaly, and the checks of ``llmpas bench validate-data``.

The package's modules are its five jobs: :mod:`~.task_files` (the suite's task folders; the
format is the household world's, :mod:`llmpas.worlds.household.household_tasks`),
:mod:`~.truth` (the success condition on the true state), :mod:`~.judge` (judging a run),
:mod:`~.task_checks` (the checks of one task that need runs) and :mod:`~.validate_data`
(``llmpas bench validate-data``). Every name is importable from here, as it was from the one
module before.

Format of a task file (``suite/household/*.toml``; see ``suite/README.md``): a household
scenario exactly as :mod:`llmpas.worlds.household.scenario` reads it — the TRUE initial world
(``[[objects]]``, ``[open]``, ``[robot]``), what the robot believes (``[belief]``), the task goal
(``[task] goal``) and the anomaly to inject and when (``[[events]]`` with ``after`` triggers, or a
belief that differs from the truth) — plus one extra table that the scenario parser never sees::

    [judge]
    category = "object-loss"        # object-loss | action-blocking | state-change
    l_gt = 7                        # ground-truth shortest resolution length (actions), >= 1
    success = "(and (On cube bowl))" # optional: checked on the TRUE final state
                                    #   (default: the task goal); and/or/not over
                                    #   On/2, Holding/1, Open/1, Dirty/1, Cleaned/1,
                                    #   Cooked/1, Heated/1, Cooled/1 (no Scanned: it is not
                                    #   a property of the world)
    effective = ["(and (scanned drawer3))", "(and (open drawer3))"]
                                    # the goal sets an expert would accept as resolving the
                                    #   anomaly (see experiments.effective for the rule)
    measures_llm = true             # optional (default false): the task belongs to the suite
                                    #   that measures the LLM: replanning the task alone
                                    #   (the replan row) must fail it

The task name (``name``) must be the file's stem.

**Resolution length** of a run: the number of plan actions completed after the first anomaly
until the loop ends (every round after the first anomalous one; actions of an interrupted round
count as far as they were completed). ``l_gt`` is the shortest resolution found from the true
anomaly state when the robot is told the truth there — the labelled oracle's goals (the oracle
reads the simulator's true state; it is an upper bound, never a default) — by the default greedy
planner under each ``PYTHONHASHSEED`` of :data:`HASH_SEEDS` (its tie-breaking depends on string
hashing) and by an optimal search (:data:`OPTIMAL_SEARCH`, :func:`optimal_resolution`).
``validate-data`` recomputes both and reports a mismatch; a planner time-out is reported as
such, never as "unreachable" (:data:`NO_VERDICT`).

**Effective goal sets** (``effective``): ``validate-data`` checks that each parses as an answer
would (the task's goal vocabulary) and that, proposed as the first answer at the anomaly (as the
oracle's goals are), the loop accepts it unchanged and plans it from the anomaly state (a run
that then does not resolve the task is a note, not an error). A task marked ``measures_llm``
must be failed by the ``replan`` baseline (:mod:`llmpas.reasoning.replan`) and by an
irrelevant goal (:func:`irrelevant_goal`): its anomaly's cause is something the robot must be
told or infer, not a fact the planner already has.

**Judging** a run (:func:`judge`): the closed loop (:func:`llmpas.system.run`) runs the task
with the given LLM and prompting method; the sample succeeds when every goal the LLM proposed
was parsed and validated (the loop rejects the others, with repairs), the planner found plans
from the anomaly state, the loop ended reporting the task done within its budget of LLM rounds,
AND the success condition holds on the simulator's TRUE final state.
"""

from llmpas.experiments.suite.judge import (
    Judgement,
    Traced,
    Verdict,
    first_anomaly,
    first_answer_goals,
    judge,
    resolution_length,
    run_traced,
)
from llmpas.experiments.suite.task_checks import (
    HASH_SEEDS,
    NO_VERDICT,
    OPTIMAL_SEARCH,
    Issue,
    OptimalSession,
    OracleRun,
    anomaly_category,
    check_task,
    effective_issues,
    irrelevant_goal,
    irrelevant_issues,
    issue_from,
    optimal_resolution,
    oracle_run,
    planner_limit,
    replan_issues,
)
from llmpas.experiments.suite.task_files import (
    ANOMALY_KINDS,
    HALVES,
    MINIMUM_COUNTS,
    SUITE_B_DIGEST,
    SUITE_B_DIR,
    SUITE_DIR,
    UNMODELLED_CAUSES,
    Category,
    SuiteError,
    SuiteTask,
    development_half,
    load_suite,
    load_task,
    parse_task,
    suite_digest,
    task_files,
    task_from_dict,
)
from llmpas.experiments.suite.truth import holds_in_truth
from llmpas.experiments.suite.validate_data import Validation, validate_folder
from llmpas.worlds.household.household_tasks import JUDGE_FIELDS, SUCCESS_PREDICATES

__all__ = [
    "ANOMALY_KINDS",
    "HALVES",
    "HASH_SEEDS",
    "JUDGE_FIELDS",
    "MINIMUM_COUNTS",
    "NO_VERDICT",
    "OPTIMAL_SEARCH",
    "SUCCESS_PREDICATES",
    "SUITE_B_DIGEST",
    "SUITE_B_DIR",
    "SUITE_DIR",
    "UNMODELLED_CAUSES",
    "Category",
    "Issue",
    "Judgement",
    "OptimalSession",
    "OracleRun",
    "SuiteError",
    "SuiteTask",
    "Traced",
    "Validation",
    "Verdict",
    "anomaly_category",
    "check_task",
    "development_half",
    "effective_issues",
    "first_anomaly",
    "first_answer_goals",
    "holds_in_truth",
    "irrelevant_goal",
    "irrelevant_issues",
    "issue_from",
    "judge",
    "load_suite",
    "load_task",
    "optimal_resolution",
    "oracle_run",
    "parse_task",
    "planner_limit",
    "replan_issues",
    "resolution_length",
    "run_traced",
    "suite_digest",
    "task_files",
    "task_from_dict",
    "validate_folder",
]
