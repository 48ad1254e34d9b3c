"""The job runner on a real Ray instance (one node on this machine with two CPUs and one
``llm``, started once for these tests and shut down after them): the same tables and plots as
the local executor, lost workers retried or reported and never cached, LLM jobs held to the
``llm`` resource, Ctrl-C, and one line when Ray is missing. (Ray itself replaces a loopback
node address with the machine's own, so no address is given.)"""

from __future__ import annotations

import csv
import io
import logging
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import ray
from rich.console import Console

from llmpas.cli import main
from llmpas.experiments.cluster import RayExecutor
from llmpas.experiments.jobs import ExecutorError, Job, JobsLost, cached, run_jobs

TIMINGS = {"latency", "wall_time", "time"}  # columns measured, not computed


@pytest.fixture(scope="module")  # one Ray start: every Ray test is here
def cluster() -> Iterator[None]:
    saved = os.environ.get("PYTHONHASHSEED")
    os.environ["PYTHONHASHSEED"] = "0"  # the workers plan as the local subprocess does
    try:
        ray.init(
            num_cpus=2,
            resources={"llm": 1},
            include_dashboard=False,
            object_store_memory=100 << 20,
            logging_level=logging.WARNING,
        )
    finally:
        if saved is None:
            os.environ.pop("PYTHONHASHSEED")
        else:
            os.environ["PYTHONHASHSEED"] = saved
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the jobs below
    yield
    ray.shutdown()


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def local_bench(argv: list[str]) -> None:
    """``llmpas bench ...`` with the local executor, in a process with the workers' hash seed
    (plans may depend on it; the executor must not)."""
    import subprocess

    env = {**os.environ, "PYTHONHASHSEED": "0"}
    cmd = [sys.executable, "-m", "llmpas.cli", "bench", *argv]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]


def rows_without_timings(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return [{k: v for k, v in r.items() if k not in TIMINGS} for r in csv.DictReader(f)]


MEASURED = {"LLM latency (s)"}  # table columns measured, not computed


def table_without_timings(path: Path) -> str:
    """A Markdown file with the measured columns of its tables blanked (the prompting table's
    LLM latency is the oracle's wall time when it reports none: a busy machine shows 0.01 where
    an idle one shows 0.00)."""
    lines: list[str] = []
    blank: set[int] = set()  # the measured columns of the table being read
    for line in path.read_text(encoding="utf-8").splitlines():
        cells = line.split("|")
        if not line.startswith("|"):
            blank = set()
        elif not lines or not lines[-1].startswith("|"):  # a table's header
            blank = {i for i, cell in enumerate(cells) if cell.strip() in MEASURED}
        lines.append("|".join("" if i in blank else c for i, c in enumerate(cells)))
    return "\n".join(lines)


def same_outputs(local: Path, remote: Path, table: str, csvs: tuple[str, ...]) -> None:
    """The table and the plot byte for byte apart from measured columns, the CSVs apart from
    timings, the same cache."""
    assert table_without_timings(remote / table) == table_without_timings(local / table)
    plot = table.replace(".md", ".png")
    assert (remote / plot).read_bytes() == (local / plot).read_bytes()
    for name in csvs:
        assert rows_without_timings(remote / name) == rows_without_timings(local / name)
    assert sorted(p.name for p in (remote / "cache").iterdir()) == sorted(
        p.name for p in (local / "cache").iterdir()
    )  # the same job keys


def test_bench_prompting_on_ray_gives_the_local_table(cluster: None, tmp_path: Path) -> None:
    args = ["prompting", "--llm", "oracle", "--methods", "flp", "--samples", "1"]
    args += ["--tasks", "ol02-table1", "ol01-table2"]
    local_bench([*args, "--out", str(tmp_path / "local")])
    assert main(["bench", *args, "--out", str(tmp_path / "ray"), "--executor", "ray"]) == 0
    csvs = ("prompting.csv", "prompting_samples.csv")
    same_outputs(tmp_path / "local", tmp_path / "ray", "prompting.md", csvs)


def test_bench_perturbation_on_ray_gives_the_local_table(cluster: None, tmp_path: Path) -> None:
    args = ["perturbation", "--episodes", "2"]
    local_bench([*args, "--out", str(tmp_path / "local")])
    assert main(["bench", *args, "--out", str(tmp_path / "ray"), "--executor", "ray"]) == 0
    local, remote = tmp_path / "local", tmp_path / "ray"
    same_outputs(local, remote, "perturbation.md", ("perturbation.csv",))


def dies_first(payload: tuple[str, int]) -> dict[str, Any]:
    """Kill this worker process on the first attempt (the marker file says it happened)."""
    marker, n = payload
    if not Path(marker).exists():
        Path(marker).write_text("killed")
        os._exit(1)
    return {"value": n * n, "pid": os.getpid()}


def always_dies(payload: tuple[str, int]) -> dict[str, Any]:
    marker, n = payload
    if n == 2:
        with Path(marker).open("a") as f:
            f.write("x")
        os._exit(1)
    return {"value": n * n}


def test_a_killed_worker_is_retried_and_the_sweep_finishes(cluster: None, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    for n in (0, 2):
        (tmp_path / f"m{n}").write_text("not this one")
    jobs = [Job(f"n{n}", (str(tmp_path / f"m{n}"), n)) for n in range(3)]
    console = quiet()
    out = run_jobs(jobs, dies_first, cache, executor=RayExecutor(retries=1), console=console)
    assert [r["value"] for r in out] == [0, 1, 4]
    assert (tmp_path / "m1").read_text() == "killed"  # job n1 really lost its first worker
    assert [cached(cache, f"n{n}") for n in range(3)] == out
    assert "1 retried" in console.file.getvalue()  # type: ignore[attr-defined]


def test_a_job_lost_on_every_attempt_is_reported_never_cached(
    cluster: None, tmp_path: Path
) -> None:
    cache, marker = tmp_path / "cache", tmp_path / "attempts"
    jobs = [Job(f"n{n}", (str(marker), n)) for n in range(4)]
    with pytest.raises(JobsLost, match=r"1 of 4 job\(s\) lost .*first: n2: 2 attempts"):
        run_jobs(jobs, always_dies, cache, executor=RayExecutor(retries=1), console=quiet())
    assert marker.read_text() == "xx"  # tried twice, no more
    assert cached(cache, "n2") is None
    assert [cached(cache, f"n{n}")["value"] for n in (0, 1, 3)] == [0, 1, 9]  # type: ignore[index]


def one_at_a_time(payload: tuple[str, int]) -> dict[str, Any]:
    """Hold a lock file for a while; a second holder at the same time is recorded."""
    import time

    folder, n = Path(payload[0]), payload[1]
    try:
        fd = os.open(folder / "lock", os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        (folder / f"overlap{n}").touch()
        return {"n": n}
    time.sleep(0.5)
    os.close(fd)
    os.unlink(folder / "lock")
    return {"n": n}


def test_llm_jobs_take_the_llm_resource(cluster: None, tmp_path: Path) -> None:
    (tmp_path / "work").mkdir()
    jobs = [Job(f"llm{n}", (str(tmp_path / "work"), n), {"llm": 1}) for n in range(3)]
    run_jobs(jobs, one_at_a_time, tmp_path / "cache", executor=RayExecutor(), console=quiet())
    assert sorted(p.name for p in (tmp_path / "work").iterdir()) == []  # one llm: never two
    missing = [Job("gpu", (str(tmp_path), 0), {"gpu-model": 1})]
    with pytest.raises(ExecutorError, match=r"offers 0 'gpu-model'.*--resources"):
        run_jobs(missing, one_at_a_time, tmp_path / "cache", executor=RayExecutor())


@pytest.mark.parametrize("bench", ["perturbation", "all"])
def test_executor_ray_without_ray_names_the_extra(
    bench: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    argv = ["bench", bench, "--executor", "ray", "--out", str(tmp_path)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "pip install 'llmpas[cluster]'" in err
    assert "Traceback" not in err and not (tmp_path / "cache").exists()


def beats(payload: tuple[str, int]) -> dict[str, Any]:
    """Job 0 ends at once; the others beat (append to a file) every 0.1 s for 20 minutes."""
    import time

    path, n = Path(payload[0]), payload[1]
    for _ in range(12_000 if n else 0):
        with path.open("a") as f:
            f.write(".")
        time.sleep(0.1)
    return {"n": n}


class InterruptAfterFirst:
    """The Ray executor, with Ctrl-C pressed on the driver once the first job has ended."""

    def __init__(self) -> None:
        self.inner = RayExecutor()

    def run(self, jobs: Any, work: Any) -> Iterator[Any]:
        from contextlib import closing

        with closing(self.inner.run(jobs, work)) as events:
            for event in events:
                yield event
                raise KeyboardInterrupt


QUIET = 3.0  # seconds without a beat: 30 beats missed by a job that still runs
STOP_GUARD = 120.0  # seconds for the jobs to stop (a guard, not a speed assertion)


def test_ctrl_c_keeps_what_finished_and_stops_the_running_jobs(
    cluster: None, tmp_path: Path
) -> None:
    import time

    beat = tmp_path / "beats"
    jobs = [Job(f"n{n}", (str(beat), n)) for n in range(3)]
    executor = InterruptAfterFirst()
    with pytest.raises(KeyboardInterrupt):
        run_jobs(jobs, beats, tmp_path / "cache", executor=executor, console=quiet())
    assert cached(tmp_path / "cache", "n0") == {"key": "n0", "n": 0}
    assert [p.name for p in (tmp_path / "cache").iterdir()] == ["n0.json"]
    # stopping takes longer on a busy machine: wait until no beat comes for QUIET seconds (a
    # running job beats every 0.1 s, for 20 minutes); a job never stopped fails at the guard
    guard = time.monotonic() + STOP_GUARD
    size, still_since = -1, time.monotonic()
    while time.monotonic() - still_since < QUIET:
        assert time.monotonic() < guard, f"jobs still beat {STOP_GUARD:g} s after Ctrl-C"
        now = beat.stat().st_size if beat.exists() else 0
        if now != size:
            size, still_since = now, time.monotonic()
        time.sleep(0.05)


def test_prompting_jobs_carry_their_task_file(tmp_path: Path) -> None:
    """A cluster's workers need not have the suite at the driver's path."""
    import shutil

    from llmpas.experiments import prompting
    from llmpas.experiments.suite import SUITE_DIR, load_suite

    shutil.copy(SUITE_DIR / "ol02-table1.toml", tmp_path)
    config = prompting.PromptingConfig(llm="oracle", methods=(), replan=False, suite=tmp_path)
    [job] = prompting.jobs_for(config, load_suite(tmp_path))
    (tmp_path / "ol02-table1.toml").unlink()
    assert prompting.run_job(job.payload)["success"] is True


def test_an_address_where_no_cluster_answers_is_one_line_not_a_wait() -> None:
    import socket

    from llmpas.experiments.cluster import reachable

    with socket.socket() as s:  # a port nobody listens on once closed
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for address in (f"127.0.0.1:{port}", f"ray://127.0.0.1:{port}"):
        with pytest.raises(ExecutorError, match=f"--ray-address {address}: no Ray cluster"):
            reachable(address)


def test_bench_all_sends_every_sweep_to_the_cluster(tmp_path: Path) -> None:
    from llmpas.cli import build_parser
    from llmpas.experiments.everything import AllConfig, plan_steps
    from llmpas.experiments.jobs import ExecutorSpec, executor_from_args

    spec = ExecutorSpec("ray", "head:6379")
    parser = build_parser()
    for step in plan_steps(AllConfig(llm="openai:m", out_dir=tmp_path, executor=spec)):
        args = parser.parse_args(step.argv)  # every sweep accepts the options
        expected = ExecutorSpec() if step.name == "validate-data" else spec
        assert executor_from_args(args) == expected


def waits_for_cpu_job(payload: tuple[str, str]) -> dict[str, Any]:
    """An LLM job that waits (a minute at most) for the CPU job's marker; the CPU job sets it."""
    import time

    marker, kind = Path(payload[0]), payload[1]
    if kind == "cpu":
        marker.touch()
        return {"saw": True}
    for _ in range(600):
        if marker.exists():
            return {"saw": True}
        time.sleep(0.1)
    return {"saw": False}


def test_jobs_waiting_for_the_llm_do_not_hold_back_cpu_jobs(cluster: None, tmp_path: Path) -> None:
    marker = str(tmp_path / "cpu-ran")
    jobs = [Job(f"llm{n}", (marker, "llm"), {"llm": 1}) for n in range(2)]
    jobs.append(Job("cpu", (marker, "cpu")))
    executor = RayExecutor(window=1)  # one job of each kind in flight
    out = run_jobs(jobs, waits_for_cpu_job, tmp_path / "cache", executor=executor, console=quiet())
    assert [r["saw"] for r in out] == [True, True, True]
