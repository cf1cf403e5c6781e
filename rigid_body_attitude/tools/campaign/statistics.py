"""What a campaign measures per run at each output time, and percentiles over the runs.

Metrics (each run, at ``t = 0`` and every output time):

* ``pointing_error_deg``: angle between the body's boresight (``statistics.boresight``, body
  axes) turned into the world frame and the target direction (``statistics.target``) [deg];
* ``nutation_deg``: angle between the boresight and the angular momentum ``h = J ω``, both in
  body axes [deg] (0 when ``h = 0``); for a spinner about the boresight, its nutation angle;
* ``momentum_change``: ``|H(t) − H(0)|`` of the world-frame angular momentum [N m s] (the drift
  of a conserved quantity in a torque-free scene; the applied impulse otherwise);
* ``energy_change``: ``T(t) − T(0)`` of the rotational kinetic energy ``½ ωᵀ J ω`` [J];
* ``rate``: ``|ω|`` [rad/s].

:func:`percentile_table` gives the requested percentiles of each metric over the runs that
did not fail, per output time.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion

__all__ = ['CLOSED_LOOP', 'METRICS', 'UNITS', 'BodyState', 'metrics', 'percentile_table',
           'pointing_error_deg']

FloatArray = NDArray[np.float64]

METRICS = ('pointing_error_deg', 'nutation_deg', 'momentum_change', 'energy_change', 'rate')
#: Per-run results of closed-loop campaigns (a scene with ``attitude_pd``).
CLOSED_LOOP = ('settling_time_s', 'torque_integral', 'torque_peak')
UNITS = {'pointing_error_deg': 'deg', 'nutation_deg': 'deg', 'momentum_change': 'N m s',
         'energy_change': 'J', 'rate': 'rad/s', 'settling_time_s': 's',
         'torque_integral': 'N m s', 'torque_peak': 'N m'}


class BodyState:
    """Attitude (n, 4), rate (n, 3) and inertia ((n, 3, 3) or (3, 3)) of n runs, with the
    derived momenta and energies."""

    def __init__(self, attitude: FloatArray, omega_body: FloatArray,
                 inertia: FloatArray) -> None:
        """Keep the state; compute ``h = J ω`` and the world-frame momentum."""
        self.attitude = attitude
        self.omega_body = omega_body
        if inertia.ndim == 2:
            self.momentum_body: FloatArray = omega_body @ inertia.T
        else:
            self.momentum_body = np.einsum('nij,nj->ni', inertia, omega_body)
        self.momentum_world = quaternion.rotate(attitude, self.momentum_body)
        self.energy: FloatArray = 0.5 * np.einsum('ni,ni->n', omega_body, self.momentum_body)


def _angle_deg(a: FloatArray, b: FloatArray) -> FloatArray:
    """Angles between rows of ``a`` and ``b`` [deg] (atan2 form: exact near 0 and 180)."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    dot = np.einsum('ni,ni->n', a, b)
    result: FloatArray = np.degrees(np.arctan2(cross, dot))
    return result


def pointing_error_deg(attitude: FloatArray, boresight: FloatArray,
                       target: FloatArray) -> FloatArray:
    """Angle [deg] between the boresight (body axes) turned into the world frame by each
    ``attitude`` (n, 4) and the ``target`` direction (world), shape (n,)."""
    n = attitude.shape[0]
    pointing = quaternion.rotate(attitude, np.broadcast_to(boresight, (n, 3)))
    return _angle_deg(pointing, np.broadcast_to(target, (n, 3)))


def metrics(state: BodyState, initial: BodyState, boresight: FloatArray,
            target: FloatArray) -> dict[str, FloatArray]:
    """Every metric of :data:`METRICS` for each run, shape (n,)."""
    n = state.attitude.shape[0]
    momentum = np.linalg.norm(state.momentum_body, axis=1)
    nutation = np.where(momentum > 0.0,
                        _angle_deg(np.broadcast_to(boresight, (n, 3)), state.momentum_body),
                        0.0)
    return {
        'pointing_error_deg': pointing_error_deg(state.attitude, boresight, target),
        'nutation_deg': nutation,
        'momentum_change': np.linalg.norm(state.momentum_world - initial.momentum_world,
                                          axis=1),
        'energy_change': state.energy - initial.energy,
        'rate': np.linalg.norm(state.omega_body, axis=1),
    }


def percentile_table(values: dict[str, FloatArray], ok: NDArray[np.bool_],
                     percentiles: Sequence[float]) -> dict[str, FloatArray]:
    """Percentiles (len(percentiles), T) of each metric's (n, T) values over the runs with
    ``ok``; NaN where no run succeeded."""
    table: dict[str, FloatArray] = {}
    every = bool(np.all(ok))
    for name, array in values.items():
        good = array if every else array[ok]
        if good.shape[0] == 0:
            table[name] = np.full((len(percentiles), array.shape[1]), np.nan)
        else:
            table[name] = np.percentile(good, list(percentiles), axis=0)
    return table
