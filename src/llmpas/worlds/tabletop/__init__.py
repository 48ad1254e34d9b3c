"""The tabletop world: the seed paper's real-world experiment as a PyBullet scene.

A Franka Panda fixed at one table puts a green cube into a bowl (``tabletop-nominal``); in
``tabletop-blocking`` the bowl already holds a black cube the robot does not know about. Written
only against :mod:`llmpas.worlds.api` and the PyBullet world's parts (a worked example of
bringing a robot: see ``docs/worlds.md``). Nothing connects to PyBullet at import time, and
this package's ``__init__`` imports nothing of it (the registry reads :data:`WORLD_ENTRY` only):
``WORLD``, ``TabletopSession`` and ``TabletopWorld`` are :mod:`.session`'s, loaded when asked.
"""

from __future__ import annotations

import importlib
from typing import Any

from llmpas.worlds.api import WorldEntry

WORLD_ENTRY = WorldEntry(
    "tabletop",
    "llmpas.worlds.tabletop.tabletop_session:WORLD",
    oracle="llmpas.worlds.tabletop.tabletop_oracle:oracle",
    rank=2,
    help="tabletop-blocking (a fixed Panda)",
)

_LAZY = ("WORLD", "TabletopSession", "TabletopWorld")


def __getattr__(name: str) -> Any:
    """The session module's names, imported on first use (it loads PyBullet's parts)."""
    if name in _LAZY:
        return getattr(importlib.import_module("llmpas.worlds.tabletop.tabletop_session"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["WORLD", "WORLD_ENTRY", "TabletopSession", "TabletopWorld"]
