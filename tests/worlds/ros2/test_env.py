"""Isolation of ROS 2 processes (no graph needed)."""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

import pytest

from llmpas.worlds.ros2.env import (
    DISCOVERY_VAR,
    RosEnv,
    from_environment,
    random_domain,
    reclaim_shared_memory,
)


def test_environment_keeps_discovery_on_localhost(tmp_path: Path) -> None:
    env = RosEnv(random_domain(), tmp_path / "log").environ({"ROS_LOCALHOST_ONLY": "0", "X": "1"})
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert "ROS_LOCALHOST_ONLY" not in env  # ignored by current ROS 2: never relied upon
    assert env["ROS_LOG_DIR"] == str(tmp_path / "log")
    assert env["X"] == "1"  # the rest passes through (the ROS wheels' bootstrap variables)


def test_the_middleware_is_the_users_unless_a_profile_names_one(tmp_path: Path) -> None:
    user = {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}
    assert RosEnv(5, tmp_path).environ(user)["RMW_IMPLEMENTATION"] == "rmw_cyclonedds_cpp"
    assert "RMW_IMPLEMENTATION" not in RosEnv(5, tmp_path).environ({})  # ROS 2's default
    chosen = RosEnv(5, tmp_path, rmw="rmw_fastrtps_cpp").environ(user)
    assert chosen["RMW_IMPLEMENTATION"] == "rmw_fastrtps_cpp"
    assert chosen["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"  # isolation stays
    with pytest.raises(ValueError, match="RMW_IMPLEMENTATION"):
        RosEnv(5, tmp_path, rmw="cyclone")


def test_a_middleware_that_is_not_installed_is_named(tmp_path: Path) -> None:
    from llmpas.worlds.ros2.env import missing_rmw

    (tmp_path / "librmw_mine.so").write_bytes(b"")
    lib = {"LD_LIBRARY_PATH": str(tmp_path)}
    assert missing_rmw({**lib, "RMW_IMPLEMENTATION": "rmw_mine"}) is None
    assert missing_rmw(lib) is None  # none named: ROS 2's default
    problem = missing_rmw({**lib, "RMW_IMPLEMENTATION": "rmw_nothing_cpp"})
    assert problem is not None and "RMW_IMPLEMENTATION=rmw_nothing_cpp" in problem


def test_a_user_widens_discovery_only_deliberately(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(DISCOVERY_VAR, raising=False)
    monkeypatch.setenv("ROS_DOMAIN_ID", "12")
    assert from_environment(tmp_path).discovery == "LOCALHOST"
    assert from_environment(tmp_path).domain == 12
    monkeypatch.setenv(DISCOVERY_VAR, "subnet")
    assert from_environment(tmp_path).discovery == "SUBNET"
    monkeypatch.setenv(DISCOVERY_VAR, "everywhere")
    with pytest.raises(ValueError, match=DISCOVERY_VAR):
        from_environment(tmp_path)


def test_domains_are_valid(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="ROS_DOMAIN_ID"):
        RosEnv(233, tmp_path)
    assert all(1 <= random_domain() <= 101 for _ in range(50))


def test_only_segments_of_ended_processes_are_reclaimed(tmp_path: Path) -> None:
    old = 1_000_000_000  # an mtime long ago
    for name in ("fastrtps_dead", "fastrtps_live", "fastrtps_young", "fastrtps_port7411"):
        for suffix in ("", "_el"):
            (tmp_path / f"{name}{suffix}").write_bytes(b"x")
            if name != "fastrtps_young":
                os.utime(tmp_path / f"{name}{suffix}", (old, old))
    held = os.open(tmp_path / "fastrtps_live_el", os.O_RDWR)
    fcntl.flock(held, fcntl.LOCK_EX)  # a live participant holds its lock
    try:
        assert reclaim_shared_memory(tmp_path) == 1
    finally:
        os.close(held)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert "fastrtps_dead" not in left and "fastrtps_dead_el" not in left
    assert {"fastrtps_live", "fastrtps_young", "fastrtps_port7411"} <= set(left)
