"""``llmpas bench validate-data``: every task file of a folder checked, statically and with
oracle runs under fixed ``PYTHONHASHSEED`` values in spawned processes."""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console

from llmpas.errors import UsageError
from llmpas.experiments.benchmarks import Bench
from llmpas.experiments.harness import SharedOptions, add_shared_arguments
from llmpas.experiments.jobs import progress_bar
from llmpas.experiments.suite.task_checks import (
    HASH_SEEDS,
    Issue,
    OracleRun,
    check_task,
    issue_from,
    oracle_run,
)
from llmpas.experiments.suite.task_files import (
    MINIMUM_COUNTS,
    SUITE_DIR,
    SuiteError,
    SuiteTask,
    load_task,
    task_files,
)
from llmpas.experiments.worlds import LoopConfig
from llmpas.planning import PlannerConfig
from llmpas.worlds.api import RunOptions

log = logging.getLogger(__name__)


def _oracle_run_file(args: tuple[str, LoopConfig, bool]) -> OracleRun:
    """:func:`oracle_run` on a task file (module level: runs in a spawned process)."""
    path, config, judge_sets = args
    try:
        return oracle_run(load_task(path), config, judge_sets=judge_sets)
    except Exception as e:  # a crash in one task is reported, the others are still checked
        log.exception("checking %s failed", path)
        issue = Issue(path, "file", f"checking crashed: {type(e).__name__}: {e}")
        return OracleRun(path, (issue,), None)


def _runs_with_hash_seed(
    tasks: Sequence[SuiteTask],
    config: LoopConfig,
    hash_seed: int,
    jobs: int,
    progress: Callable[[str], None] | None,
    judge_sets: bool = False,
) -> list[OracleRun]:
    """Oracle runs of ``tasks`` in fresh processes with ``PYTHONHASHSEED=hash_seed``."""
    import multiprocessing
    import os
    from concurrent.futures import ProcessPoolExecutor

    before = os.environ.get("PYTHONHASHSEED")
    os.environ["PYTHONHASHSEED"] = str(hash_seed)  # read by the spawned interpreters
    try:
        context = multiprocessing.get_context("spawn")
        # one fresh process per run: a run never depends on what ran before it (counters,
        # caches), so the result is the same whatever the order and the number of jobs
        with ProcessPoolExecutor(
            max_workers=jobs, mp_context=context, max_tasks_per_child=1
        ) as pool:
            futures = [pool.submit(_oracle_run_file, (t.source, config, judge_sets)) for t in tasks]
            runs = []
            for t, f in zip(tasks, futures, strict=True):
                runs.append(f.result())
                if progress is not None:
                    progress(t.name)
    finally:
        if before is None:
            os.environ.pop("PYTHONHASHSEED", None)
        else:
            os.environ["PYTHONHASHSEED"] = before
    return runs


@dataclass(frozen=True)
class Validation:
    tasks: tuple[SuiteTask, ...]
    issues: tuple[Issue, ...]
    checked: int  # files looked at
    replan: Mapping[str, str] = field(default_factory=dict)  # task -> the replan verdict
    notes: tuple[Issue, ...] = ()  # remarks that are not errors (effective sets)

    @property
    def ok(self) -> bool:
        return not self.issues


def validate_folder(
    folder: str | Path = SUITE_DIR,
    config: LoopConfig | None = None,
    *,
    hash_seeds: Sequence[int] = HASH_SEEDS,
    jobs: int = 1,
    expect_counts: bool | None = None,
    progress: Callable[[str], None] | None = None,
) -> Validation:
    """Check every task file of ``folder``: static errors (format, unknown names), then oracle
    runs with each of ``hash_seeds`` in ``jobs`` spawned processes (see :func:`oracle_run` and
    :func:`check_task`; no hash seeds: one run in this process). ``expect_counts``: require the
    shipped suite's task counts (:data:`MINIMUM_COUNTS` per category; default: only for the
    shipped folder).
    ``progress`` is called once per file and per oracle run."""
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    config = config or LoopConfig()
    folder = Path(folder)
    issues: list[Issue] = []
    try:
        files = task_files(folder)
    except SuiteError as e:
        return Validation((), (Issue(str(folder), "folder", str(e).split(": ", 1)[-1]),), 0)
    if not files:
        return Validation((), (Issue(str(folder), "folder", "no task files (*.toml)"),), 0)
    tasks: list[SuiteTask] = []
    for path in files:
        try:
            tasks.append(load_task(path))
        except SuiteError as e:
            issues.append(issue_from(e, str(path)))
            if progress is not None:  # no oracle runs for it either
                for _ in range(max(1, len(hash_seeds))):
                    progress(path.stem)
        if progress is not None:
            progress(path.stem)
    runs: dict[str, list[OracleRun]] = {t.source: [] for t in tasks}
    if hash_seeds:  # effective sets and the replan baseline: with the first hash seed
        for k, seed in enumerate(hash_seeds):
            for r in _runs_with_hash_seed(tasks, config, seed, jobs, progress, k == 0):
                runs[r.source].append(r)
    else:
        for t in tasks:
            runs[t.source].append(_oracle_run_file((t.source, config, True)))
            if progress is not None:
                progress(t.name)
    exact = set(HASH_SEEDS) <= set(hash_seeds)
    replan: dict[str, str] = {}
    notes: list[Issue] = []
    for t in tasks:
        issues.extend(check_task(t, runs[t.source], exact=exact))
        replan[t.name] = next((r.replan for r in runs[t.source] if r.replan), "")
        notes.extend(n for r in runs[t.source] for n in r.notes if n not in notes)
    if expect_counts is None:
        expect_counts = folder.resolve() == SUITE_DIR.resolve()
    if expect_counts and len(tasks) == len(files):
        for cat, n in MINIMUM_COUNTS.items():
            have = sum(t.category is cat for t in tasks)
            if have < n:
                issues.append(
                    Issue(
                        str(folder),
                        "judge.category",
                        f"{have} {cat.value} tasks, expected at least {n}",
                    )
                )
    return Validation(tuple(tasks), tuple(issues), len(files), replan, tuple(notes))


# ------------------------------------------------------------------------------------ CLI


def add_validate_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``llmpas bench validate-data``."""
    p.add_argument("folder", nargs="?", default=str(SUITE_DIR), help="folder of task files")
    p.add_argument(
        "--seeds",
        type=int,
        default=len(HASH_SEEDS),
        help="oracle runs per task, with PYTHONHASHSEED 0, 1, ... (l_gt: the shortest found); "
        "0: one run in this process",
    )
    p.add_argument(
        "--max-time",
        type=float,
        default=600.0,
        help="planner safety net, seconds per plan (counted limits decide the verdict)",
    )
    add_shared_arguments(
        p, SharedOptions(jobs_help="oracle runs in parallel processes", executor=False)
    )


def validate_command(args: argparse.Namespace, console: Console) -> int:
    """``llmpas bench validate-data``: one line per mistake; exit status 1 when any."""
    if args.seeds < 0 or args.jobs < 1:
        raise UsageError("--seeds must be >= 0 and --jobs >= 1")
    folder = Path(args.folder)
    config = LoopConfig(
        options=RunOptions(planner=PlannerConfig.validation(max_time=args.max_time))
    )
    try:
        files = len(task_files(folder))
    except SuiteError:
        files = 0
    total = files * (1 + max(1, args.seeds))
    with progress_bar(console, "validating", total) as advance:
        result = validate_folder(
            folder,
            config,
            hash_seeds=tuple(range(args.seeds)),  # 0, 1, ...: HASH_SEEDS by default
            jobs=args.jobs,
            progress=lambda _name: advance(),
        )
    for note in result.notes:
        console.print(f"[yellow]note[/]: {note}", highlight=False, soft_wrap=True)
    for issue in result.issues:
        console.print(f"[bold red]error[/]: {issue}", highlight=False, soft_wrap=True)
    if result.replan:
        failed = sum(v != "success" for v in result.replan.values())
        console.print(
            f"replan (the task goal restated) fails {failed} of {len(result.replan)} tasks: "
            + ", ".join(f"{t} {v}" for t, v in sorted(result.replan.items())),
            highlight=False,
            soft_wrap=True,
        )
    if result.ok:
        console.print(f"[bold green]ok[/]: {len(result.tasks)} task files in {folder}")
        return 0
    console.print(f"{len(result.issues)} problem(s) in {result.checked} task files")
    return 1


BENCHMARK = Bench(
    "validate-data",
    "check the household suite's task files",
    add_validate_arguments,
    validate_command,
    lambda config: None if config.quick else config.jobs_argv(),
)
