"""Cache integrity and failure semantics of the job runner: a bad entry of any kind is
recomputed with one warning line (never used, never a traceback), results marked not cacheable
and failed jobs are never stored, an interrupt keeps what finished, lost jobs are reported after
the others finish, and the progress bar counts outcomes."""

from __future__ import annotations

import io
import json
import logging
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest
from rich.console import Console

from llmpas.experiments.jobs import (
    SCHEMA,
    Event,
    ExecutorSpec,
    Job,
    JobsLost,
    LocalExecutor,
    Outcome,
    Work,
    cache_file,
    cached,
    checksum,
    executor_from_args,
    llm_resources,
    not_cacheable,
    run_jobs,
    store,
)


def triple(n: int) -> dict[str, Any]:
    return {"value": 3 * n, "pair": (n, n)}


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def _entry(tmp_path: Path, key: str = "k") -> tuple[Path, dict[str, Any]]:
    store(tmp_path, key, {"value": 12, "name": "x"})
    path = cache_file(tmp_path, key)
    return path, json.loads(path.read_text())


def _rewrite(path: Path, entry: dict[str, Any]) -> None:
    path.write_text(json.dumps(entry))


def _flip_one_byte(path: Path) -> None:
    raw = bytearray(path.read_bytes())
    i = raw.index(b"12")  # inside the result: the file stays valid JSON
    raw[i] = ord("9")
    path.write_bytes(bytes(raw))


def _drop_field(path: Path) -> None:
    entry = json.loads(path.read_text())
    del entry["checksum"]
    _rewrite(path, entry)


def _old_schema(path: Path) -> None:
    entry = json.loads(path.read_text())
    _rewrite(path, {"key": entry["key"], **entry["result"]})  # the format before schemas


def _tamper(path: Path) -> None:
    entry = json.loads(path.read_text())
    entry["result"]["value"] = 13
    _rewrite(path, entry)


def _not_utf8(path: Path) -> None:
    path.write_bytes(path.read_bytes().replace(b'"x"', b'"\xff\xfe"'))


def _utf16(path: Path) -> None:
    path.write_bytes(path.read_text().encode("utf-16"))


def _truncate(path: Path) -> None:
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])


def _deep(path: Path) -> None:
    path.write_text("[" * 100_000 + "]" * 100_000)


def _wrong_key(path: Path) -> None:
    entry = json.loads(path.read_text())
    entry["key"] = "other"
    _rewrite(path, entry)


def _result_not_object(path: Path) -> None:
    entry = json.loads(path.read_text())
    entry["result"] = [1, 2]
    entry["checksum"] = "0"
    _rewrite(path, entry)


CORRUPTIONS = {
    "one bad byte": (_flip_one_byte, "checksum mismatch"),
    "missing field": (_drop_field, "missing field 'checksum'"),
    "wrong schema": (_old_schema, "schema None"),
    "tampered value": (_tamper, "checksum mismatch"),
    "not UTF-8": (_not_utf8, "not UTF-8"),
    "UTF-16": (_utf16, "not UTF-8"),
    "truncated": (_truncate, "not JSON"),
    "nested too deeply": (_deep, "nested too deeply"),
    "another key": (_wrong_key, "holds key 'other'"),
    "result not an object": (_result_not_object, "not a JSON object"),
}


@pytest.mark.parametrize("kind", list(CORRUPTIONS))
def test_a_bad_entry_is_recomputed_with_one_warning_line(
    tmp_path: Path, kind: str, caplog: pytest.LogCaptureFixture
) -> None:
    corrupt, reason = CORRUPTIONS[kind]
    path, _ = _entry(tmp_path)
    corrupt(path)
    calls: list[int] = []

    def work(n: int) -> dict[str, Any]:
        calls.append(n)
        return {"value": 12, "name": "x"}

    with caplog.at_level(logging.WARNING):
        out = run_jobs([Job("k", 4)], work, tmp_path, console=quiet())
    assert calls == [4]  # recomputed, the bad entry was not used
    assert out == [{"key": "k", "value": 12, "name": "x"}]
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "\n" not in warnings[0]
    assert str(path) in warnings[0] and reason in warnings[0]
    assert cached(tmp_path, "k") == out[0]  # rewritten, now good


def test_an_entry_carries_its_schema_and_the_checksum_of_its_result(tmp_path: Path) -> None:
    path, entry = _entry(tmp_path)
    assert entry["schema"] == SCHEMA
    assert entry["checksum"] == checksum({"value": 12, "name": "x"})
    assert checksum({"value": 12, "name": "x"}) != checksum({"value": 13, "name": "x"})
    assert path.read_bytes().isascii()


def test_results_read_back_as_they_were_returned_when_fresh(tmp_path: Path) -> None:
    fresh = run_jobs([Job("a", 2)], triple, tmp_path, console=quiet())
    again = run_jobs([Job("a", 2)], triple, tmp_path, console=quiet())
    assert fresh == again == [{"key": "a", "value": 6, "pair": [2, 2]}]


def test_lone_surrogates_in_a_result_are_stored_and_read_back(tmp_path: Path) -> None:
    out = run_jobs([Job("s", 0)], lambda _: {"text": "a\udc80b"}, tmp_path, console=quiet())
    assert cached(tmp_path, "s") == out[0] == {"key": "s", "text": "a\udc80b"}


def test_keys_that_differ_only_in_unsafe_characters_get_different_files(tmp_path: Path) -> None:
    assert cache_file(tmp_path, "a/b") != cache_file(tmp_path, "a_b")
    run_jobs([Job("a/b", 1), Job("a_b", 2)], triple, tmp_path, console=quiet())
    assert cached(tmp_path, "a/b") == {"key": "a/b", "value": 3, "pair": [1, 1]}
    assert cached(tmp_path, "a_b") == {"key": "a_b", "value": 6, "pair": [2, 2]}


def crashed_once(n: int) -> dict[str, Any]:
    if n == 2:
        return not_cacheable({"value": -1, "status": "crashed"}, "the planner crashed")
    return {"value": n, "status": "solved"}


def test_a_result_marked_not_cacheable_is_used_once_and_never_stored(tmp_path: Path) -> None:
    jobs = [Job(f"n{n}", n) for n in (1, 2, 3)]
    console = quiet()
    out = run_jobs(jobs, crashed_once, tmp_path, console=console)
    assert out[1] == {"key": "n2", "value": -1, "status": "crashed"}  # no marker left in it
    assert cached(tmp_path, "n2") is None and not cache_file(tmp_path, "n2").exists()
    assert cached(tmp_path, "n1") is not None and cached(tmp_path, "n3") is not None
    assert "2 ran · 1 not cached" in console.file.getvalue()  # type: ignore[attr-defined]


def interrupted(n: int) -> dict[str, Any]:
    if n == 3:
        raise KeyboardInterrupt
    return {"value": n}


def test_an_interrupt_keeps_what_finished_and_leaves_nothing_half_written(tmp_path: Path) -> None:
    jobs = [Job(f"n{n}", n) for n in range(1, 6)]
    with pytest.raises(KeyboardInterrupt):
        run_jobs(jobs, interrupted, tmp_path, console=quiet())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        cache_file(tmp_path, k).name for k in ("n1", "n2")
    )
    calls: list[int] = []

    def resume(n: int) -> dict[str, Any]:
        calls.append(n)
        return {"value": n}

    out = run_jobs(jobs, resume, tmp_path, console=quiet())
    assert calls == [3, 4, 5] and [r["value"] for r in out] == [1, 2, 3, 4, 5]


def test_an_interrupt_while_writing_leaves_no_entry_and_no_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import os

    def interrupt(*_: Any) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupt)
    with pytest.raises(KeyboardInterrupt):
        run_jobs([Job("w", 1)], triple, tmp_path, console=quiet())
    assert list(tmp_path.iterdir()) == []


def test_a_local_pool_job_error_keeps_the_finished_results(tmp_path: Path) -> None:
    jobs = [Job(f"n{n}", n) for n in (1, 2, -1)]
    with pytest.raises(ValueError, match="negative"):
        run_jobs(jobs, _checked, tmp_path, executor=LocalExecutor(2), console=quiet())
    assert cached(tmp_path, "n-1") is None
    assert not list(tmp_path.glob(".*tmp"))


def _checked(n: int) -> dict[str, Any]:
    if n < 0:
        raise ValueError("negative")
    return {"value": n}


class Flaky:
    """An in-memory executor whose workers get lost: ``losses[key]`` attempts of that job are
    lost before it runs (more than ``retries``: it is reported lost)."""

    def __init__(self, losses: Mapping[str, int], retries: int) -> None:
        self.losses = dict(losses)
        self.retries = retries
        self.ran: list[str] = []

    def run(self, jobs: Sequence[Job[Any]], work: Work) -> Iterator[Event]:
        for job in jobs:
            for attempt in range(self.retries + 1):
                if attempt < self.losses.get(job.key, 0):
                    last = attempt == self.retries
                    yield Event(job.key, Outcome.LOST if last else Outcome.RETRIED, detail="gone")
                    continue
                self.ran.append(job.key)
                yield Event(job.key, Outcome.RAN, work(job.payload))
                break


def test_lost_jobs_are_reported_after_the_others_finish_and_never_cached(
    tmp_path: Path,
) -> None:
    jobs = [Job(f"n{n}", n) for n in range(4)]
    flaky = Flaky({"n1": 1, "n2": 5}, retries=1)
    console = quiet()
    with pytest.raises(JobsLost, match=r"1 of 4 job\(s\) lost .*first: n2: gone"):
        run_jobs(jobs, triple, tmp_path, executor=flaky, console=console)
    assert flaky.ran == ["n0", "n1", "n3"]  # n1 retried, the sweep went on after n2
    assert [k for k in ("n0", "n1", "n2", "n3") if cached(tmp_path, k)] == ["n0", "n1", "n3"]
    assert "3 ran · 2 retried · 1 lost" in console.file.getvalue()  # type: ignore[attr-defined]
    out = run_jobs(jobs, triple, tmp_path, executor=Flaky({}, 1), console=quiet())
    assert [r["value"] for r in out] == [0, 3, 6, 9]


def test_cached_results_are_counted_on_the_progress_bar(tmp_path: Path) -> None:
    run_jobs([Job("a", 1)], triple, tmp_path, console=quiet())
    console = quiet()
    run_jobs([Job("a", 1), Job("b", 2)], triple, tmp_path, console=console)
    assert "1 cached · 1 ran" in console.file.getvalue()  # type: ignore[attr-defined]


def test_executor_options_are_validated() -> None:
    import argparse

    assert executor_from_args(argparse.Namespace()) == ExecutorSpec()
    ray = executor_from_args(argparse.Namespace(executor="ray", ray_address="h:6379"))
    assert ray.argv() == ("--executor", "ray", "--ray-address", "h:6379")
    with pytest.raises(ValueError, match="--ray-address needs --executor ray"):
        executor_from_args(argparse.Namespace(executor="local", ray_address="h:6379"))
    with pytest.raises(ValueError, match="--executor 'slurm'"):
        ExecutorSpec("slurm")


def test_only_jobs_that_talk_to_a_model_ask_for_the_llm_resource() -> None:
    assert llm_resources("oracle") == {} and llm_resources("replay:cassettes") == {}
    assert llm_resources("openai:gpt-4o-mini") == {"llm": 1.0}
    assert llm_resources("llama-cpp") == {"llm": 1.0}
    with pytest.raises(ValueError, match="amount > 0"):
        Job("k", 1, {"llm": 0})


def test_benches_never_cache_a_crashed_planner(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from llmpas.experiments import perturbation, planning_time

    def crashed_trial(example: str, size: int, mode: str, trial: int, _: Any) -> Any:
        status = "solved" if mode == "deferred" else "crashed"
        return planning_time.Trial(example, size, mode, trial, status, 1.0, 0, 0, 0, 0, 3)

    monkeypatch.setattr(planning_time, "run_trial", crashed_trial)
    bench = planning_time.BenchConfig(examples=("tamp2d",), sizes=(2,), trials=1, out_dir=tmp_path)
    report = planning_time.run_planning_time(bench, quiet())
    assert sorted(t.status for t in report.trials) == ["crashed", "solved"]  # shown this run
    assert [p.name.split("_")[2] for p in (tmp_path / "cache").iterdir()] == ["deferred"]

    def crashed_episode(k: int, mode: str, config: Any) -> Any:
        status = "plan-crashed" if mode == "flat" else "success"
        return perturbation.Outcome(k, mode, "pose 0.0", status, 0, 1, 1.0)

    monkeypatch.setattr(perturbation, "run_episode", crashed_episode)
    config = perturbation.PerturbationConfig(episodes=1, out_dir=tmp_path / "p")
    outcomes, _ = perturbation.run_perturbation(config, quiet())
    assert [o.status for o in outcomes] == ["success", "plan-crashed"]
    assert [p.name.split("_")[0] for p in (tmp_path / "p" / "cache").iterdir()] == ["csubbt"]
