"""``python -m llmpas.worlds.pybullet_ros2 SCENARIO ...``: the robot's process (started by the
ROS 2 world's session), with the command's one parser."""

from llmpas.worlds.pybullet_ros2.robot_command import main

raise SystemExit(main())
