"""Simulated sensors of a dynamics scene (its ``sensors:`` section): pure NumPy models.

* :mod:`~rigid_body_attitude.core.sensors.imu`: a strapdown IMU (gyroscope and accelerometer)
  with the kalibr-named error model of the attitude covariance.
* :mod:`~rigid_body_attitude.core.sensors.magnetometer`: a three-axis magnetometer with hard
  and soft iron.
* :mod:`~rigid_body_attitude.core.sensors.star_tracker`: a star tracker's attitude and its
  covariance about world axes.
* :mod:`~rigid_body_attitude.core.sensors.suite`: the section as a whole.
"""

from rigid_body_attitude.core.sensors.imu import ImuModel, ImuSpec, imu_spec
from rigid_body_attitude.core.sensors.magnetometer import (
    MagnetometerModel, MagnetometerSpec, magnetometer_spec)
from rigid_body_attitude.core.sensors.star_tracker import (
    StarTrackerModel, StarTrackerSpec, star_tracker_spec)
from rigid_body_attitude.core.sensors.suite import SensorSuite, sensors_section

__all__ = ['ImuModel', 'ImuSpec', 'MagnetometerModel', 'MagnetometerSpec', 'SensorSuite',
           'StarTrackerModel', 'StarTrackerSpec', 'imu_spec', 'magnetometer_spec',
           'sensors_section', 'star_tracker_spec']
