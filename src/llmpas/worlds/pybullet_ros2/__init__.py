"""The PyBullet Husky + Franka Panda served as a ROS 2 robot (``llmpas robot pybullet``): the
simulator behind Nav2's, ros2_control's and a detector's standard interfaces (or llmpas's own).
It is a robot like any other to the client (:mod:`llmpas.worlds.ros2`), which never imports it.
"""

from llmpas.worlds.api import RobotEntry

ROBOT_ENTRY = RobotEntry("pybullet", "llmpas.worlds.pybullet_ros2.robot_command:run")
