"""Attitude control laws, pure NumPy: what a controller node and the batch engine both run."""

from __future__ import annotations

from rigid_body_attitude.core.control.allocation import minimum_norm_allocation, wheel_torques
from rigid_body_attitude.core.control.magnetic import (
    bdot_dipole, bdot_dipole_rows, dumping_dipole, dumping_dipole_rows)
from rigid_body_attitude.core.control.quaternion_pd import (
    as_axis_gains, pd_torque_body, pd_torque_floats)

__all__ = ['as_axis_gains', 'bdot_dipole', 'bdot_dipole_rows', 'dumping_dipole',
           'dumping_dipole_rows', 'minimum_norm_allocation', 'pd_torque_body',
           'pd_torque_floats', 'wheel_torques']
