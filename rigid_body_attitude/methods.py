"""Name → integrator lookup used by scenes and propagators.

Two kinds of method, each an object with ``name``, ``order`` and a docstring:

* dynamics integrators: ``supports_torque`` and
  ``step(attitude, omega_body, t, h, model) -> (attitude, omega_body)``;
* strapdown methods: ``reset()`` and
  ``propagate(q, omega_previous, omega_current, dt) -> q`` (plain tuples, hot path).
"""

from __future__ import annotations

from typing import Any

from rigid_body_attitude import quaternion
from rigid_body_attitude.dynamics import RigidBodyModel, rk4_step
from rigid_body_attitude.errors import IntegratorError

__all__ = ['dynamics_integrator', 'strapdown_method']


class RigidBodyRk4:
    """Classical RK4 on (q, ω) with renormalisation; see :func:`dynamics.rk4_step`."""

    name = 'rk4'
    order = 4
    supports_torque = True

    def step(self, attitude: Any, omega_body: Any, t: float, h: float,
             model: RigidBodyModel) -> tuple[Any, Any]:
        """One RK4 step of ``h`` seconds."""
        return rk4_step(model, t, attitude, omega_body, h)


class ExpMapHeld:
    """``q ⊗ exp(dt ω_k)``, the rate of the interval's first sample held (order 1)."""

    name = 'exp_map'
    order = 1
    input_kind = 'rate'

    def reset(self) -> None:
        """No history to forget."""

    def propagate(self, q: Any, omega_previous: Any, omega_current: Any,
                  dt: float) -> tuple[float, float, float, float]:
        """One step over ``dt`` with ``omega_previous`` held."""
        return quaternion.scalar_exp_step(q, omega_previous, dt)


_DYNAMICS = {'rk4': RigidBodyRk4}
_STRAPDOWN = {'exp_map': ExpMapHeld}


def dynamics_integrator(name: str) -> Any:
    """A new dynamics integrator by name; :class:`IntegratorError` lists the valid names."""
    if name not in _DYNAMICS:
        raise IntegratorError(f'Unknown dynamics integrator {name!r}; valid choices: '
                              f'{", ".join(sorted(_DYNAMICS))}')
    return _DYNAMICS[name]()


def strapdown_method(name: str) -> Any:
    """A new strapdown method by name; :class:`IntegratorError` lists the valid names."""
    if name not in _STRAPDOWN:
        raise IntegratorError(f'Unknown strapdown method {name!r}; valid choices: '
                              f'{", ".join(sorted(_STRAPDOWN))}')
    return _STRAPDOWN[name]()
