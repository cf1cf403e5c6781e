"""Attitude: quaternion algebra and conventions, kinematics, attitude-only integrators.

Conventions are stated once, in :mod:`rigid_body_attitude.core.attitude.quaternion`. Nothing
here knows a body's inertia: the rates are given (a gyro's samples or a function of time).
"""
