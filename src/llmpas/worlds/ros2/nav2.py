"""Nav2's error codes (Jazzy): what a failed NavigateToPose goal's ``error_code`` means."""

from __future__ import annotations

# Nav2 (Jazzy): the navigator's result carries the failing task server's code:
# nav2_msgs/action/ComputePathToPose 200-208, FollowPath 100-106, the navigator's own 9000s.
PLANNER_CODES = {
    200: "unknown",
    201: "invalid_planner",
    202: "tf",
    203: "start_outside_map",
    204: "blocked",  # GOAL_OUTSIDE_MAP
    205: "start_occupied",
    206: "blocked",  # GOAL_OCCUPIED
    207: "timeout",
    208: "blocked",  # NO_VALID_PATH
}
CONTROLLER_CODES = {
    100: "unknown",
    101: "invalid_controller",
    102: "tf",
    103: "invalid_path",
    104: "stuck",  # PATIENCE_EXCEEDED
    105: "stuck",  # FAILED_TO_MAKE_PROGRESS
    106: "stuck",  # NO_VALID_CONTROL
}
NO_VALID_PATH = 208


def nav2_reason(code: int) -> str:
    """The failure's reason for a NavigateToPose ``error_code`` (``aborted`` when unknown)."""
    if code in PLANNER_CODES:
        return PLANNER_CODES[code]
    if code in CONTROLLER_CODES:
        return CONTROLLER_CODES[code]
    if code == 9003:
        return "timeout"
    if code == 9002:
        return "tf"
    return "aborted"


__all__ = ["CONTROLLER_CODES", "NO_VALID_PATH", "PLANNER_CODES", "nav2_reason"]
