"""The action servers a client speaks to, by key, and their names on one robot (its profile's)."""

from __future__ import annotations

from llmpas.worlds.ros2.profile import RobotProfile

NAV = "navigate_to_pose"
FJT = "arm_controller/follow_joint_trajectory"
GRIPPER = "gripper_controller/gripper_cmd"
SKILL = "llmpas/skill"
LOOK = "llmpas/look"
STATE = "llmpas/scene_state"
ACTIONS = (NAV, FJT, GRIPPER, SKILL, LOOK)
STANDARD = (NAV, FJT, GRIPPER)  # the actions a standard robot serves


def action_names(profile: RobotProfile) -> dict[str, str]:
    """Each action's name on this robot (relative names resolve in the node's namespace)."""
    a = profile.actions
    return {NAV: a.navigate, FJT: a.arm, GRIPPER: a.gripper, SKILL: a.skill, LOOK: a.look}


__all__ = ["ACTIONS", "FJT", "GRIPPER", "LOOK", "NAV", "SKILL", "STANDARD", "STATE", "action_names"]
