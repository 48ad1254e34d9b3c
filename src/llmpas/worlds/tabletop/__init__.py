"""The tabletop world: the seed paper's real-world experiment as a PyBullet scene.

A Franka Panda fixed at one table puts a green cube into a bowl (``tabletop-nominal``); in
``tabletop-blocking`` the bowl already holds a black cube the robot does not know about. Written
only against :mod:`llmpas.worlds.api` and the PyBullet world's parts (a worked example of
bringing a robot: see ``docs/worlds.md``). Nothing connects to PyBullet at import time.
"""

from llmpas.worlds.tabletop.session import WORLD, TabletopSession, TabletopWorld

__all__ = ["WORLD", "TabletopSession", "TabletopWorld"]
