"""Integrators: the exact torque-free solution, strapdown (gyro-driven) updates, dynamics.

Conventions are those of :mod:`rigid_body_attitude.quaternion`.
"""
