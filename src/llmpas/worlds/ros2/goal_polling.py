"""The standard robot's skills as steps polled by the tick (:class:`Steps`): each step sends one
action goal (:class:`Send`), waits for it without blocking (:class:`_Goal`: acceptance and
result watched against the client's timeouts, cancelled on request) or runs slow work off the
tick's thread (:class:`Later`).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from llmpas.execution.robot_protocols import SkillResult

if TYPE_CHECKING:  # the robot these steps drive
    from llmpas.worlds.ros2.standard_robot import StandardRobot

log = logging.getLogger(__name__)


def stamp_seconds(stamp: Any) -> float:
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


@dataclass(frozen=True)
class Send:
    """A step's goal: ``check`` reads the action's result (None: go on; a result: the skill
    ends with it)."""

    action: str
    goal: Any
    check: Callable[[Any], SkillResult | None] = lambda raw: None


class Later:
    """Work a step runs off the tick's thread (planning a trajectory): ``poll()`` is None
    until it is done, then the step's outcome (a :class:`Send`, a :class:`SkillResult`, or
    None to go on)."""

    def __init__(self, robot: StandardRobot, work: Callable[[], Send | SkillResult | None]) -> None:
        self.outcome: list[Send | SkillResult | None] = []
        self.error: list[BaseException] = []
        robot.planning += 1

        def run() -> None:
            try:
                with robot.scene_lock:
                    self.outcome.append(work())
            except BaseException as e:  # re-raised on the tick's thread
                self.error.append(e)
            finally:
                robot.planning -= 1

        self.thread = threading.Thread(target=run, daemon=True, name="llmpas-plan")
        self.thread.start()

    @property
    def done(self) -> bool:
        return bool(self.outcome or self.error)

    def poll(self) -> Send | SkillResult | None:
        if self.error:
            raise self.error[0]
        return self.outcome[0]


Step = Callable[[], "Send | SkillResult | Later | None"]


class Steps:
    """A skill as goals sent one after another (a step returns a :class:`Send`, a final
    :class:`SkillResult`, work to run off the tick's thread (:class:`Later`), or None to go
    on). ``poll()`` never blocks: RUNNING while a goal or the work is under way."""

    def __init__(self, robot: StandardRobot, steps: list[Step], done: SkillResult) -> None:
        self.robot, self.steps, self.done = robot, list(steps), done
        self.final: SkillResult | None = None
        self.current: _Goal | None = None
        self.later: Later | None = None

    def poll(self) -> SkillResult:
        while self.final is None:
            if self.later is not None:
                if not self.later.done:
                    self.robot.polls_planning += 1
                    return SkillResult.still_running("planning a trajectory")
                later, self.later = self.later, None
                self._take(later.poll())
                continue
            if self.current is not None:
                raw = self.current.poll()
                if raw is None:
                    return SkillResult.still_running(f"{self.current.name}: goal running")
                goal, self.current = self.current, None
                if isinstance(raw, SkillResult):
                    self.final = raw
                    break
                checked = goal.check(raw)
                if checked is not None:
                    self.final = checked
                continue
            if not self.steps:
                self.final = self.done
                break
            self._take(self.steps.pop(0)())
        return self.final

    def _take(self, out: Send | SkillResult | Later | None) -> None:
        if isinstance(out, SkillResult):
            self.final = out
        elif isinstance(out, Send):
            self.current = _Goal(self.robot, out)
        elif isinstance(out, Later):
            self.later = out

    def cancel(self) -> None:
        """Cancel the goal under way on the robot (off the tick's thread); the skill ends
        (cancelled)."""
        if self.final is not None:
            return
        if self.current is not None:
            self.current.cancel()
        self.final = SkillResult.failure("cancelled", reason="cancelled")


class _Goal:
    """One goal: sent once its server is there (polled: never waited for), then polled until
    its result and the joint states stamped after it have come."""

    def __init__(self, robot: StandardRobot, send: Send) -> None:
        self.robot, self.send, self.check = robot, send, send.check
        self.name = robot.names[send.action]
        self.client = robot.clients[send.action]
        self.handle: Any = None
        self.result: Any = None
        self.wrapped: Any = None
        self.after: float | None = None  # the robot's latest stamp when the result came
        self.gone: float | None = None
        self.sent: Any = None
        self.failed: SkillResult | None = None
        self.deadline = time.monotonic() + robot.timeouts.lost  # for the server to be there

    def _send(self, now: float) -> None:
        robot, send = self.robot, self.send
        robot.goals += 1
        robot.moved(send.action)
        robot.on_goal(f"{self.name}/goal", "Goal", send.goal)
        self.sent = robot.request(
            lambda: self.client.send_goal_async(
                send.goal,
                feedback_callback=lambda f: robot.on_goal(
                    f"{self.name}/feedback", "Feedback", f.feedback
                ),
            )
        )
        self.deadline = now + robot.timeouts.accept

    def _watch(self, now: float, what: str) -> None:
        """The server's presence: gone for longer than ``timeouts.lost`` ends the run."""
        if self.client.server_is_ready():
            self.gone = None
        elif self.gone is None:
            self.gone = now
        elif now - self.gone > self.robot.timeouts.lost:
            raise self.robot.lost_error(self.send.action, what)

    def poll(self) -> SkillResult | Any | None:
        """None while running; a failure; or the action's result (it succeeded)."""
        from action_msgs.msg import GoalStatus

        if self.failed is not None:
            return self.failed
        now = time.monotonic()
        if self.sent is None:  # the server not there yet (discovery, polled)
            if self.client.server_is_ready():
                self._send(now)
            elif now > self.deadline:
                raise self.robot.lost_error(self.send.action, "is gone")
            return None
        if self.handle is None:
            if not self.sent.done():
                self.robot.polls_accepting += 1
                self._watch(now, "vanished before accepting a goal")
                return self._late(now, "did not answer the goal", "lost")
            handle = self.sent.result()
            if not handle.accepted:
                return SkillResult.failure(f"{self.name} rejected the goal", reason="rejected")
            self.handle, self.result = handle, self.robot.request(handle.get_result_async)
            self.deadline = now + self.robot.timeouts.goal
        if self.wrapped is None:
            if not self.result.done():
                if now > self.deadline:
                    self.cancel()
                    return SkillResult.failure(f"{self.name} timed out", reason="timeout")
                self._watch(now, "vanished during a goal")
                return None
            self.wrapped = self.result.result()
            self.robot.on_goal(f"{self.name}/result", "Result", self.wrapped.result)
            self.after = self.robot.latest_stamp()
            self.deadline = now + self.robot.timeouts.settle
        # joint states stamped after the result (the robot's own clock), polled
        if self.robot.joints_stamp <= (self.after or 0.0) and now <= self.deadline:
            return None
        self.robot.sync()
        if self.wrapped.status == GoalStatus.STATUS_SUCCEEDED:
            return self.wrapped.result
        return self.robot.failure(self.send.action, self.wrapped)

    def _late(self, now: float, what: str, reason: str) -> SkillResult | None:
        if now > self.deadline:
            return SkillResult.failure(f"{self.name} {what}", reason=reason)
        return None

    def cancel(self) -> None:
        """Ask the server to cancel, off the tick's thread (a goal not accepted yet is
        cancelled once it is)."""
        robot, sent, handle = self.robot, self.sent, self.handle
        if sent is None:
            return  # never sent

        def cancel() -> None:
            goal = handle
            if goal is None:
                if not robot.wait(sent, robot.timeouts.accept):
                    return
                goal = sent.result()
                if not goal.accepted:
                    return
            reply = robot.request(goal.cancel_goal_async)
            robot.cancels += 1
            if not robot.wait(reply, robot.timeouts.cancel):
                log.warning("%s: no reply to a cancel within %g s", self.name,
                            robot.timeouts.cancel)  # fmt: skip

        threading.Thread(target=cancel, daemon=True, name="llmpas-cancel").start()
