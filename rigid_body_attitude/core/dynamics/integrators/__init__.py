"""Dynamics integrators: the coupled attitude/Euler equations, and the exact torque-free solution.

Conventions are those of :mod:`rigid_body_attitude.core.attitude.quaternion`. One menu, a
mapping name → class (instantiate for a fresh, independent integrator):

* :data:`DYNAMICS_INTEGRATORS` — ``step(attitude, omega_body, t, h, model)`` on the coupled
  attitude/Euler equations, with ``model`` a :class:`~.base.BodyModel`: ``rk4``, ``rkmk4``,
  ``strang``, ``yoshida4``, ``casimir6``, ``casimir8``, ``rkn4``, ``rkn6``, ``dopri45``,
  ``exact`` (torque-free only).

The attitude-only menus (strapdown on gyro samples, kinematic steps for a rate known in time)
are in :mod:`rigid_body_attitude.core.attitude.integrators`.

Every class documents its equation, order, cost, invariants and source.
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.dynamics.integrators.adaptive import DormandPrince45
from rigid_body_attitude.core.dynamics.integrators.base import (
    BodyModel, DynamicsIntegrator, SimpleBodyModel)
from rigid_body_attitude.core.dynamics.integrators.dynamics_base import (
    DYNAMICS_INTEGRATORS, torque_integrators)
from rigid_body_attitude.core.dynamics.integrators.exact_step import ExactTorqueFree
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion
from rigid_body_attitude.core.dynamics.integrators.rigid_body_rk4 import RigidBodyRk4
from rigid_body_attitude.core.dynamics.integrators.rkmk4 import RigidBodyRkmk4
from rigid_body_attitude.core.dynamics.integrators.splitting import (
    BlanesMoan4Splitting, BlanesMoan6Splitting, Casimir6Splitting, Casimir8Splitting,
    StrangSplitting, Yoshida4Splitting)

__all__ = [
    'BodyModel',
    'DYNAMICS_INTEGRATORS',
    'DynamicsIntegrator',
    'SimpleBodyModel',
    'TorqueFreeMotion',
    'dynamics_integrator',
    'torque_integrators',
]

for _cls in (RigidBodyRk4, RigidBodyRkmk4, StrangSplitting, Yoshida4Splitting,
             Casimir6Splitting, Casimir8Splitting, BlanesMoan4Splitting, BlanesMoan6Splitting,
             DormandPrince45, ExactTorqueFree):
    DYNAMICS_INTEGRATORS.register(_cls)


def dynamics_integrator(name: str, **options: Any) -> Any:
    """A fresh dynamics integrator by name (``options`` go to its constructor, e.g. the
    tolerances of ``dopri45``): a :class:`~.dynamics_base.DynamicsMethod` (typed ``Any`` so
    callers may read a method's own attributes, e.g. dopri45's counters);
    :class:`IntegratorError` lists the valid names."""
    cls = DYNAMICS_INTEGRATORS.lookup(name)
    try:
        return cls(**options)
    except TypeError as err:
        raise IntegratorError(f'Unexpected options {sorted(options)!r} for dynamics '
                              f'integrator {name!r}') from err
