"""The Ray executor of the job runner (:mod:`llmpas.experiments.jobs`): jobs run as Ray tasks on
a cluster (``pip install 'llmpas[cluster]'``; see docs/cluster.md).

- Scheduling: every job takes one CPU; a job with resources (an LLM-bound job asks for one
  ``llm``) runs only on nodes that offer them. Resources the cluster does not have are refused
  before anything runs, and again if the nodes offering them leave while jobs wait.
- Results come back to the driver, which writes them into its own cache folder (the workers
  never touch it): no shared folder is needed, and a sweep resumes with either executor.
- A job whose worker or node is lost is submitted again, at most ``retries`` times, and then
  reported as lost (never cached); the other jobs go on. An exception raised by a job stops the
  sweep as it does locally. Closing the event iterator (Ctrl-C) cancels the jobs still running.
"""

from __future__ import annotations

import logging
import os
import socket
from collections import Counter, deque
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from llmpas.experiments.jobs import Event, ExecutorError, Job, Outcome, Work

log = logging.getLogger(__name__)

EXTRA = "pip install 'llmpas[cluster]'"
POLL = 5.0  # seconds between checks that the cluster can still run the waiting jobs
PROBE = 10.0  # seconds a cluster's address has to accept a connection


def import_ray() -> Any:
    """The ``ray`` module, or ExecutorError naming the extra that installs it."""
    try:
        import ray
    except ImportError:
        raise ExecutorError(f"--executor ray needs Ray: {EXTRA}") from None
    return ray


def connect(ray: Any, address: str | None) -> None:
    """Join the cluster at ``address`` (None: ``RAY_ADDRESS``, else start Ray on this machine);
    an already initialised Ray (a test's, or an earlier sweep's) is used as it is."""
    if ray.is_initialized():
        return
    address = address or os.environ.get("RAY_ADDRESS") or None
    where = address or "a local Ray instance"
    if address is not None:
        reachable(address)
    log.info("connecting to %s", where)
    try:
        ray.init(address=address, logging_level=logging.WARNING)
    except Exception as e:  # Ray raises ConnectionError, ValueError, RuntimeError, ...
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ExecutorError(
            f"--ray-address {where}: cannot join the Ray cluster: {first}"
        ) from None


def reachable(address: str, timeout: float = PROBE) -> None:
    """ExecutorError unless ``HOST:PORT`` (or ``ray://HOST:PORT``) accepts a connection within
    ``timeout`` seconds: Ray itself would wait for a cluster that is not there. ``auto`` and
    other forms are left to Ray."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        return
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
            pass
    except OSError as e:
        reason = e.strerror or type(e).__name__
        raise ExecutorError(
            f"--ray-address {address}: no Ray cluster answers there ({reason})"
        ) from None


def _needs(jobs: Sequence[Job[Any]]) -> dict[str, float]:
    need: dict[str, float] = {"CPU": 1.0}
    for job in jobs:
        for name, amount in job.resources.items():
            need[name] = max(need.get(name, 0.0), float(amount))
    return need


def check_resources(ray: Any, need: Mapping[str, float]) -> None:
    """ExecutorError when no node of the cluster offers what a job needs (it would wait
    forever)."""
    have = ray.cluster_resources()
    for name, amount in need.items():
        if have.get(name, 0.0) < amount:
            resources = f"--resources='{{\"{name}\": 1}}'" if name != "CPU" else "--num-cpus=1"
            raise ExecutorError(
                f"the Ray cluster offers {have.get(name, 0.0):g} {name!r}, a job needs {amount:g}: "
                f"start a node with `ray start --address=HEAD:6379 {resources}` "
                "(see docs/cluster.md)"
            )


def _call(work: Work, payload: Any) -> dict[str, Any]:
    """The Ray task: one job (module level, so Ray can ship it)."""
    return dict(work(payload))


@dataclass(frozen=True)
class RayExecutor:
    """Jobs as Ray tasks on the cluster at ``address``; a lost job runs at most ``retries``
    more times. At most ``window`` jobs of each kind (the same resources) are submitted at once
    (None: twice the cluster's CPUs), so the driver's memory stays bounded however long the
    sweep."""

    address: str | None = None
    retries: int = 2
    window: int | None = None

    def __post_init__(self) -> None:
        if self.retries < 0:
            raise ValueError(f"retries must be >= 0, got {self.retries}")
        if self.window is not None and self.window < 1:
            raise ValueError(f"window must be >= 1, got {self.window}")

    def run(self, jobs: Sequence[Job[Any]], work: Work) -> Iterator[Event]:
        """Join the cluster and check its resources now (before any progress is shown), then
        run the jobs as the events are read."""
        ray = import_ray()
        connect(ray, self.address)
        need = _needs(jobs)
        check_resources(ray, need)
        return self._events(ray, jobs, work, need)

    def _events(
        self, ray: Any, jobs: Sequence[Job[Any]], work: Work, need: Mapping[str, float]
    ) -> Iterator[Event]:
        task = ray.remote(_call)
        window = self.window or max(2, 2 * int(ray.cluster_resources().get("CPU", 1)))
        lost_errors = _lost_errors(ray)
        queue = deque((job, 0) for job in jobs)
        pending: dict[Any, tuple[Job[Any], int]] = {}
        try:
            while queue or pending:
                self._fill(task, work, queue, pending, window)
                ready, _ = ray.wait(list(pending), num_returns=1, timeout=POLL)
                if not ready:
                    check_resources(ray, need)
                    continue
                job, attempt = pending.pop(ready[0])
                try:
                    result = ray.get(ready[0])
                except ray.exceptions.RayTaskError as err:  # the job raised: as locally
                    cause = getattr(err, "cause", None)
                    raise (cause if isinstance(cause, Exception) else err) from None
                except lost_errors as err:
                    detail = _first_line(err)
                    if attempt < self.retries:
                        queue.append((job, attempt + 1))
                        yield Event(job.key, Outcome.RETRIED, detail=detail)
                    else:
                        yield Event(
                            job.key, Outcome.LOST, detail=f"{attempt + 1} attempts: {detail}"
                        )
                    continue
                yield Event(job.key, Outcome.RAN, result)
        finally:  # done, an error, or Ctrl-C: nothing keeps running for this sweep
            for ref in pending:
                try:
                    ray.cancel(ref, force=True)
                except Exception as e:  # already finished or gone
                    log.debug("cancel: %s", e)

    def _fill(
        self,
        task: Any,
        work: Work,
        queue: deque[tuple[Job[Any], int]],
        pending: dict[Any, tuple[Job[Any], int]],
        window: int,
    ) -> None:
        """Submit queued jobs, in order, while fewer than ``window`` of their kind (the same
        resources) are in flight: LLM jobs waiting for an ``llm`` never hold back CPU jobs."""
        busy = Counter(_shape(job) for job, _ in pending.values())
        for _ in range(len(queue)):
            job, attempt = queue.popleft()
            if busy[_shape(job)] < window:
                pending[self._submit(task, work, job)] = (job, attempt)
                busy[_shape(job)] += 1
            else:
                queue.append((job, attempt))

    @staticmethod
    def _submit(task: Any, work: Work, job: Job[Any]) -> Any:
        return task.options(
            num_cpus=1,
            resources=dict(job.resources) or None,
            max_retries=0,  # retried here, so every lost attempt is counted and reported
            retry_exceptions=False,
            name=job.key[:200],
        ).remote(work, job.payload)


def _shape(job: Job[Any]) -> tuple[tuple[str, float], ...]:
    return tuple(sorted(job.resources.items()))


def _lost_errors(ray: Any) -> tuple[type[BaseException], ...]:
    """Ray's errors for a job that did not fail by itself: its worker or node went away."""
    names = (
        "WorkerCrashedError",
        "NodeDiedError",
        "ObjectLostError",
        "LocalRayletDiedError",
        "OutOfMemoryError",
        "TaskCancelledError",
    )
    return tuple(getattr(ray.exceptions, n) for n in names if hasattr(ray.exceptions, n))


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return f"{type(err).__name__}: {text.splitlines()[0] if text else ''}".rstrip(": ")


__all__ = ["EXTRA", "RayExecutor", "check_resources", "connect", "import_ray"]
