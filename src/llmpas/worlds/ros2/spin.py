"""The client node's executor, spun in a thread of its own, shared by both ROS 2 clients
(:class:`~llmpas.worlds.ros2.client.RosRobot` and
:class:`~llmpas.worlds.ros2.standard_robot.StandardRobot`).

rclpy files a request's future only after sending it: a reply the spinner takes in between is
dropped ("Ignoring unexpected goal response") and the goal never answers. So requests are sent
(:meth:`Spinner.request`) and replies taken (the spinner) under one lock."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

log = logging.getLogger(__name__)
T = TypeVar("T")


class Spinner:
    """Spins ``node`` until :meth:`shutdown`; never blocks a shutdown on a busy spin."""

    def __init__(self, node: Any, context: Any) -> None:
        from rclpy.executors import SingleThreadedExecutor

        self.node = node
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(node)
        self.lock = threading.Lock()
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True, name="ros2-spin")
        self.thread.start()

    def _spin(self) -> None:
        try:
            while not self.stopping.is_set():
                with self.lock:
                    self.executor.spin_once(timeout_sec=0.005)
                time.sleep(0.0005)  # a sender waiting for the lock gets it
        except Exception:  # the context was shut down under it
            log.debug("ROS 2 spinner stopped", exc_info=True)

    def request(self, send: Callable[[], T]) -> T:
        """``send()`` (a goal, result, cancel or service request) while no reply is taken."""
        with self.lock:
            return send()

    @staticmethod
    def wait(future: Any, seconds: float) -> bool:
        """Whether ``future`` is done within ``seconds`` (the spinner thread completes it)."""
        end = time.monotonic() + seconds
        while not future.done():
            if time.monotonic() > end:
                return False
            time.sleep(0.002)
        return True

    def shutdown(self) -> None:
        """Stop spinning; the node goes with its context when the spinner does not stop."""
        self.stopping.set()
        self.thread.join(timeout=2.0)
        self.executor.shutdown(timeout_sec=2.0)
        if not self.thread.is_alive():
            self.node.destroy_node()
