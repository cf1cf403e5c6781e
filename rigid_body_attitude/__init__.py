"""Rigid-body attitude propagation: a pure NumPy core and thin ROS 2 shells over it.

The core (every module here except ``node``, ``replay`` and the benchmark CLIs) never imports
rclpy. Conventions are stated once, in :mod:`rigid_body_attitude.core.attitude.quaternion`.
"""

__version__ = '0.1.0'
