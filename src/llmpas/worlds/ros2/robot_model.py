"""The robot's body from its ``robot_description`` (the URDF robot_state_publisher latches),
for the planning scene: the arm (the subtree from the parent link of the profile's first arm
joint) as a URDF of its own for PyBullet, the mount (the base frame to the arm's root, through
the description's fixed joints) and the base's collision boxes.

Mesh files a client cannot read (``package://`` references off the robot, relative paths) are
left out, and said so: visuals do not matter for planning, and a collision mesh left out is a
link the planner cannot check (the log names them). Nothing is read from a model file of
llmpas or pybullet_data: the description is the only source.
"""

from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

log = logging.getLogger(__name__)

Vec = tuple[float, float, float]


class DescriptionError(ValueError):
    """A robot_description the planner cannot use."""


@dataclass(frozen=True)
class Box:
    """A collision box: half extents and centre (in the base frame), yaw about z."""

    half: Vec
    centre: Vec
    yaw: float = 0.0


@dataclass(frozen=True)
class ArmModel:
    """What the planning scene loads: the arm's URDF text, the mount (x, y, z, yaw of the arm's
    root in the base frame), the base's collision boxes, the arm's joints in the URDF's order
    and the links whose collision meshes could not be read."""

    urdf: str
    root: str
    mount: tuple[float, float, float, float]
    base: tuple[Box, ...]
    joints: tuple[str, ...]
    dropped: tuple[str, ...] = ()


def _floats(text: str | None, n: int = 3) -> tuple[float, ...]:
    values = tuple(float(v) for v in (text or " ".join(["0"] * n)).split())
    if len(values) != n:
        raise DescriptionError(f"{text!r}: {n} numbers")
    return values


def _end(joint: ET.Element, tag: str) -> str:
    """The link at a joint's ``parent`` or ``child``."""
    element = joint.find(tag)
    if element is None or not element.get("link"):
        raise DescriptionError(f"joint {joint.get('name')!r}: no {tag} link")
    return str(element.get("link"))


def _readable(filename: str) -> bool:
    if filename.startswith("file://"):
        filename = filename[len("file://") :]
    return Path(filename).is_absolute() and Path(filename).is_file()


def _strip_meshes(link: ET.Element) -> bool:
    """Remove meshes the client cannot read from a link; whether a collision was removed."""
    dropped = False
    for tag in ("visual", "collision"):
        for element in list(link.findall(tag)):
            mesh = element.find("geometry/mesh")
            if mesh is not None and not _readable(mesh.get("filename", "")):
                link.remove(element)
                dropped = dropped or tag == "collision"
    return dropped


def _planar(origin: ET.Element | None) -> tuple[float, float, float, float]:
    """x, y, z, yaw of a joint's origin (roll and pitch must be zero: a mount on a base)."""
    if origin is None:
        return (0.0, 0.0, 0.0, 0.0)
    x, y, z = _floats(origin.get("xyz"))
    roll, pitch, yaw = _floats(origin.get("rpy"))
    if abs(roll) > 1e-6 or abs(pitch) > 1e-6:
        raise DescriptionError("the arm's mount is tilted (roll or pitch): not supported")
    return (x, y, z, yaw)


def _compose(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    c, s = math.cos(a[3]), math.sin(a[3])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2], a[3] + b[3])


def _boxes(link: ET.Element, at: tuple[float, float, float, float]) -> list[Box]:
    """A base link's collision primitives as boxes in the base frame (a cylinder or a sphere:
    its bounding box)."""
    out = []
    for collision in link.findall("collision"):
        geometry = collision.find("geometry")
        if geometry is None or len(geometry) == 0:
            continue
        shape = geometry[0]
        if shape.tag == "box":
            half = tuple(v / 2 for v in _floats(shape.get("size")))
        elif shape.tag == "cylinder":
            r, length = float(shape.get("radius", "0")), float(shape.get("length", "0"))
            half = (r, r, length / 2)
        elif shape.tag == "sphere":
            r = float(shape.get("radius", "0"))
            half = (r, r, r)
        else:
            continue
        x, y, z, yaw = _compose(at, _planar(collision.find("origin")))
        out.append(Box((half[0], half[1], half[2]), (x, y, z), yaw))
    return out


def arm_model(description: str, first_joint: str, base_frame: str) -> ArmModel:
    """The arm of ``description`` whose first joint is ``first_joint``, mounted on
    ``base_frame`` (a link of the description, or the arm's root itself)."""
    try:
        root = ET.fromstring(description)
    except ET.ParseError as e:
        raise DescriptionError(f"not URDF: {e}") from None
    if root.tag != "robot":
        raise DescriptionError("not URDF: no <robot> element")
    links = {link.get("name", ""): link for link in root.findall("link")}
    joints = root.findall("joint")
    parent_of: dict[str, ET.Element] = {}
    for j in joints:
        parent_of[_end(j, "child")] = j
    first = next((j for j in joints if j.get("name") == first_joint), None)
    if first is None:
        raise DescriptionError(f"no joint {first_joint!r}")
    arm_root = _end(first, "parent")
    children: dict[str, list[ET.Element]] = {}
    for j in joints:
        children.setdefault(_end(j, "parent"), []).append(j)
    subtree, frontier = {arm_root}, [arm_root]
    while frontier:
        for j in children.get(frontier.pop(), []):
            child = _end(j, "child")
            subtree.add(child)
            frontier.append(child)
    # the mount: from the base frame up to the arm's root through fixed joints
    mount = (0.0, 0.0, 0.0, 0.0)
    if base_frame != arm_root:
        chain, link = [], arm_root
        while link != base_frame:
            up = parent_of.get(link)
            if up is None:
                raise DescriptionError(f"the arm's root {arm_root} does not hang from {base_frame}")
            if up.get("type") != "fixed":
                raise DescriptionError(f"the joint {up.get('name')} between {base_frame} and the "
                                       f"arm is not fixed")  # fmt: skip
            chain.append(_planar(up.find("origin")))
            link = _end(up, "parent")
        for step in reversed(chain):
            mount = _compose(mount, step)
    # the base's boxes: the links outside the arm, placed through fixed joints from the base
    base: list[Box] = []
    placed = {base_frame: (0.0, 0.0, 0.0, 0.0)}
    frontier = [base_frame]
    while frontier:
        name = frontier.pop()
        if name in links and name not in subtree:
            base += _boxes(links[name], placed[name])
        for j in children.get(name, []):
            child = _end(j, "child")
            if child in subtree or j.get("type") != "fixed":
                continue
            placed[child] = _compose(placed[name], _planar(j.find("origin")))
            frontier.append(child)
    arm = ET.Element("robot", name=root.get("name", "robot") + "_arm")
    dropped = []
    for link_name, element in links.items():
        if link_name in subtree:
            copy = ET.fromstring(ET.tostring(element))
            if _strip_meshes(copy):
                dropped.append(link_name)
            arm.append(copy)
    order = []
    for j in joints:
        if _end(j, "parent") in subtree:
            arm.append(ET.fromstring(ET.tostring(j)))
            if j.get("type") != "fixed":
                order.append(j.get("name", ""))
    if dropped:
        log.warning("robot_description: the collision meshes of %s cannot be read here "
                    "(left out of the planning scene's checks)", ", ".join(dropped))  # fmt: skip
    return ArmModel(ET.tostring(arm, encoding="unicode"), arm_root, mount, tuple(base),
                    tuple(order), tuple(dropped))  # fmt: skip


__all__ = ["ArmModel", "Box", "DescriptionError", "arm_model"]
