"""Attitude-only integrators: ``q̇ = ½ q ⊗ (0, ω)`` for a rate that is given.

Two menus, each a mapping name → class (instantiate for a fresh, independent integrator):

* :data:`STRAPDOWN_METHODS` — ``propagate(q, omega_previous, omega_current, dt)`` on a
  stream of gyro samples (:mod:`.strapdown`);
* :data:`KINEMATIC_METHODS` — ``step(q, omega_of_time, t, h)`` for a rate known as a function
  of time (:mod:`.kinematic`), the accuracy study's menu; :mod:`.angles` integrates Euler
  angles and the direction-cosine matrix for comparison.
"""

from __future__ import annotations

from rigid_body_attitude.core.attitude.integrators.kinematic import (
    KINEMATIC_METHODS, kinematic_method)
from rigid_body_attitude.core.attitude.integrators.strapdown import (
    STRAPDOWN_METHODS, strapdown_method)

__all__ = ['KINEMATIC_METHODS', 'STRAPDOWN_METHODS', 'kinematic_method', 'strapdown_method']
