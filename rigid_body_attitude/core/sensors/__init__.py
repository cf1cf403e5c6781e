"""Simulated sensors of a dynamics scene (its ``sensors:`` section): pure NumPy models.

* :mod:`~rigid_body_attitude.core.sensors.imu`: a strapdown IMU (gyroscope and accelerometer)
  with the kalibr-named error model of the attitude covariance.
"""

from rigid_body_attitude.core.sensors.imu import ImuModel, ImuSpec, imu_spec, sensors_spec

__all__ = ['ImuModel', 'ImuSpec', 'imu_spec', 'sensors_spec']
