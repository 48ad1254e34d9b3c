"""The extras of llmpas, with the ROS 2 interface packages built from this checkout.

``pip install -e ".[ros]"`` builds the wheels of ``ros/nav2_msgs``, ``ros/control_msgs``,
``ros/tf2_msgs``, ``ros/vision_msgs`` and ``ros/llmpas_interfaces`` (their ``.action``/``.msg``
files, with the ROS wheels' code generators). A dependency on a folder needs an absolute
``file://`` URL, so it is computed here; everything else is in pyproject.toml
(``[tool.llmpas.extras]``)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from setuptools import setup

ROOT = Path(__file__).resolve().parent
INTERFACES = {  # distribution -> folder under ros/
    "llmpas-nav2-msgs": "nav2_msgs",
    "llmpas-control-msgs": "control_msgs",
    "llmpas-tf2-msgs": "tf2_msgs",
    "llmpas-vision-msgs": "vision_msgs",
    "llmpas-interfaces": "llmpas_interfaces",
}


def extras() -> dict[str, list[str]]:
    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["llmpas"]["extras"]
    out = {name: list(reqs) for name, reqs in table.items()}
    out["ros"] = out.get("ros", []) + [
        f"{dist} @ {(ROOT / 'ros' / folder).as_uri()}" for dist, folder in INTERFACES.items()
    ]
    return out


setup(extras_require=extras())
