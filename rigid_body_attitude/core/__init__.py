"""The pure core: quaternions, inertia, dynamics, effects, integrators, scenes, propagators.

NumPy only; nothing here imports rclpy, the session layer or the tools. Conventions are stated
once, in :mod:`rigid_body_attitude.core.quaternion`.
"""
