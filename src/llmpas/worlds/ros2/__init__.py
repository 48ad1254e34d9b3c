"""The closed loop over ROS 2: the robot's skills and perception are action goals and topics of
a robot (the PyBullet Husky + Panda as a ROS 2 node, or a real robot), and every run is recorded
as a rosbag2-format MCAP. Needs the ``ros`` extra (``pip install -e ".[ros]"``); docs/ros.md."""

from llmpas.worlds.api import WorldEntry

WORLD_ENTRY = WorldEntry(
    "ros2",
    "llmpas.worlds.ros2.ros2_plugin:WORLD",
    oracle="llmpas.worlds.pybullet.pybullet_oracle:oracle",  # the simulated robot's truth
    rank=3,
    sites=True,
)
