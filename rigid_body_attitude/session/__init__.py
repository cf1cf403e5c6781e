"""The node without ROS: time rules, counting, fault handling and outputs.

Fed decoded inputs with their times by the node (:mod:`rigid_body_attitude.ros`) and by the
replay tool (:mod:`rigid_body_attitude.tools.replay`) alike, so both give the same numbers.
Imports the core, never rclpy.
"""
