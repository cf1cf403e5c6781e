"""The pure core: attitude math, rigid-body dynamics, the IMU's models, and the propagators.

NumPy only; nothing here imports rclpy, the session layer or the tools. Rooms:
:mod:`.attitude` (quaternions, kinematics, strapdown integrators), :mod:`.dynamics` (inertia,
Euler's equations, effects, dynamics integrators, scenes), :mod:`.imu` (calibration, levelling,
rest detection, error model, covariance); :mod:`.propagator` advances the state from either.
Conventions are stated once, in :mod:`rigid_body_attitude.core.attitude.quaternion`.
"""
