"""The TF buffer: chains through static and dynamic edges, time-stamped lookups."""

from __future__ import annotations

import math

import pytest

from llmpas.worlds.ros2.tf import TfBuffer, TfError, Transform


def close(a: tuple[float, ...], b: tuple[float, ...], tol: float = 1e-9) -> bool:
    return all(abs(x - y) < tol for x, y in zip(a, b, strict=True))


def test_a_chain_map_odom_base_camera() -> None:
    tf = TfBuffer()
    tf.add("map", "odom", 0.0, Transform.planar(1.0, 0.0, 0.0), static=True)
    tf.add("odom", "base_link", 10.0, Transform.planar(2.0, 0.0, math.pi / 2))
    tf.add("base_link", "camera", 0.0, Transform((0.5, 0.0, 1.0)), static=True)
    base = tf.lookup("map", "base_link")
    assert close(base.translation, (3.0, 0.0, 0.0)) and abs(base.yaw - math.pi / 2) < 1e-9
    # a point 1 m ahead of the camera: the base faces +y, so it is at y = 1.5 in map
    p = tf.lookup("map", "camera").apply((1.0, 0.0, 0.0))
    assert close(p, (3.0, 1.5, 1.0))
    # and back: the inverse chain
    q = tf.lookup("camera", "map").apply(p)
    assert close(q, (1.0, 0.0, 0.0))


def test_lookup_interpolates_between_stamps_and_refuses_far_times() -> None:
    tf = TfBuffer(tolerance=0.2)
    tf.add("odom", "base_link", 1.0, Transform.planar(0.0, 0.0, 0.0))
    tf.add("odom", "base_link", 3.0, Transform.planar(2.0, 0.0, math.pi / 2))
    mid = tf.lookup("odom", "base_link", 2.0)
    assert close(mid.translation, (1.0, 0.0, 0.0)) and abs(mid.yaw - math.pi / 4) < 1e-9
    assert close(tf.lookup("odom", "base_link", 3.1).translation, (2.0, 0.0, 0.0))
    assert close(tf.lookup("odom", "base_link").translation, (2.0, 0.0, 0.0))  # latest
    with pytest.raises(TfError, match="no transform at"):
        tf.lookup("odom", "base_link", 5.0)


def test_unconnected_frames_and_history_bound() -> None:
    tf = TfBuffer(history=3)
    tf.add("map", "a", 0.0, Transform(), static=True)
    tf.add("odom", "b", 0.0, Transform())
    with pytest.raises(TfError, match="no transform chain"):
        tf.lookup("map", "b")
    for k in range(10):
        tf.add("odom", "b", float(k), Transform.planar(float(k), 0.0, 0.0))
    with pytest.raises(TfError):
        tf.lookup("odom", "b", 0.0)  # dropped: only the last three are kept
    assert close(tf.lookup("odom", "b", 8.5).translation, (8.5, 0.0, 0.0))
    assert tf.frames() == {"map", "a", "odom", "b"}
