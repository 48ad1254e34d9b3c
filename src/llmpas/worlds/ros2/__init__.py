"""The closed loop over ROS 2: the robot's skills and perception are action goals and topics of
a robot (the PyBullet Husky + Panda as a ROS 2 node, or a real robot), and every run is recorded
as a rosbag2-format MCAP. Needs the ``ros`` extra (``pip install -e ".[ros]"``); docs/ros.md."""
