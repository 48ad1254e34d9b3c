"""LLM-PAS on a simulated Husky + Franka Panda in PyBullet (issue #6).

- :mod:`.scene` — the bodies in one explicit physics client (``open_client`` / ``open_scene``).
- :mod:`.camera` — mast and wrist cameras (TinyRenderer), detection from segmentation + depth.
- :mod:`.kinematics` — IK verified by FK with re-seeding; collision checks.
- :mod:`.motion` — OMPL RRT-Connect for the arm, SE(2) planning for the base.
- :mod:`.skills` — base motion with odometry noise, pre-approach/approach/grasp/place/release.
- :mod:`.snapshot` — overview PNGs and GIFs.
- :mod:`.streams`, :mod:`.problem`, :mod:`.decomposition`, :mod:`.world` — the household PDDL
  domain and streams with real geometry, the belief, CSubBT specs and the Robot/Perception adapter.
- :mod:`.run` (scenarios, ``run_scenario``), :mod:`.loop` (closed loop with a reasoner),
  :mod:`.cli`.

Nothing connects to PyBullet at import time.
"""

from llmpas.worlds.api import WorldEntry

WORLD_ENTRY = WorldEntry(
    "pybullet",
    "llmpas.worlds.pybullet.pybullet_plugin:WORLD",
    oracle="llmpas.worlds.pybullet.pybullet_oracle:oracle",
    rank=1,
    help="object-loss, action-blocking (PyBullet Husky + Panda)",
)
