"""What a campaign measures per run at each output time, and percentiles over the runs.

Metrics (each run, at ``t = 0`` and every output time):

* ``pointing_error_deg``: angle between the body's boresight (``statistics.boresight``, body
  axes) turned into the world frame and the target direction (``statistics.target``) [deg];
* ``nutation_deg``: angle between the boresight and the momentum of the body's own rotation
  ``h = J ω`` (wheels held), both in body axes [deg]; for a spinner about the boresight, its
  nutation angle. Defined only for a run turning at ``|ω| ≥ statistics.nutation_min_rate``
  (default :data:`NUTATION_MIN_RATE`, a tenth of a low orbit's rate): slower, ``h`` is a
  rounding-level vector whose direction means nothing (a spacecraft settled at rest), so the
  run has no nutation at that time (NaN) and is left out of that time's percentiles;
* ``momentum_change``: ``|H(t) − H(0)|`` of the world-frame angular momentum [N m s], wheels
  included (the drift of a conserved quantity in a torque-free scene; the applied impulse
  otherwise);
* ``energy_change``: ``T(t) − T(0)`` of the kinetic energy ``½ ωᵀ J ω`` [J] (with wheels
  ``½ ωᵀ J' ω + Σ Hᵢ²/(2 Jₛᵢ)``);
* ``rate``: ``|ω|`` [rad/s].

Per run, with actuators in the scene (:data:`ACTUATORS`): the peak wheel speed ``max |Ωᵢ|``
[rad/s] over the wheels and the run, the time [s] during which the speed limit cut a wheel's
motor torque, and the momentum dumped, ``∫|m × B| dt`` of the magnetorquers [N m s].

:func:`percentile_table` gives the requested percentiles of each metric over the runs that
did not fail and for which the metric is defined, per output time (NaN where none is).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion

__all__ = ['ACTUATORS', 'CLOSED_LOOP', 'METRICS', 'NUTATION_MIN_RATE', 'UNITS', 'BodyState',
           'metrics', 'percentile_table', 'pointing_error_deg']

FloatArray = NDArray[np.float64]

METRICS = ('pointing_error_deg', 'nutation_deg', 'momentum_change', 'energy_change', 'rate')
#: Per-run results of closed-loop campaigns (a scene with ``attitude_pd``).
CLOSED_LOOP = ('settling_time_s', 'torque_integral', 'torque_peak')
#: Per-run results of scenes with reaction wheels or magnetorquers.
ACTUATORS = ('wheel_speed_peak', 'wheel_time_saturated_s', 'momentum_dumped')
UNITS = {'pointing_error_deg': 'deg', 'nutation_deg': 'deg', 'momentum_change': 'N m s',
         'energy_change': 'J', 'rate': 'rad/s', 'settling_time_s': 's',
         'torque_integral': 'N m s', 'torque_peak': 'N m', 'wheel_speed_peak': 'rad/s',
         'wheel_time_saturated_s': 's', 'momentum_dumped': 'N m s'}
#: Default rate [rad/s] below which a run has no nutation (``statistics.nutation_min_rate``).
NUTATION_MIN_RATE = 1.0e-4


class BodyState:
    """Attitude (n, 4), rate (n, 3) and inertia ((n, 3, 3) or (3, 3)) of n runs, with the
    derived momenta and energies."""

    def __init__(self, attitude: FloatArray, omega_body: FloatArray, inertia: FloatArray,
                 total_momentum_body: FloatArray | None = None,
                 energy: FloatArray | None = None) -> None:
        """Keep the state; compute ``h = J ω``, the world-frame momentum (from
        ``total_momentum_body`` when wheels hold some) and the energy (``energy`` if given).
        """
        self.attitude = attitude
        self.omega_body = omega_body
        if inertia.ndim == 2:
            self.momentum_body: FloatArray = omega_body @ inertia.T
        else:
            self.momentum_body = np.einsum('nij,nj->ni', inertia, omega_body)
        total = self.momentum_body if total_momentum_body is None else total_momentum_body
        self.momentum_world = quaternion.rotate(attitude, total)
        self.energy: FloatArray = (0.5 * np.einsum('ni,ni->n', omega_body, self.momentum_body)
                                   if energy is None else energy)


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
            target: FloatArray,
            nutation_min_rate: float = NUTATION_MIN_RATE) -> dict[str, FloatArray]:
    """Every metric of :data:`METRICS` for each run, shape (n,) (``nutation_deg`` NaN for
    a run turning slower than ``nutation_min_rate`` [rad/s])."""
    n = state.attitude.shape[0]
    rate = np.linalg.norm(state.omega_body, axis=1)
    nutation = np.where((rate >= nutation_min_rate) & (rate > 0.0),
                        _angle_deg(np.broadcast_to(boresight, (n, 3)), state.momentum_body),
                        np.nan)
    return {
        'pointing_error_deg': pointing_error_deg(state.attitude, boresight, target),
        'nutation_deg': nutation,
        'momentum_change': np.linalg.norm(state.momentum_world - initial.momentum_world,
                                          axis=1),
        'energy_change': state.energy - initial.energy,
        'rate': rate,
    }


def percentile_table(values: dict[str, FloatArray], ok: NDArray[np.bool_],
                     percentiles: Sequence[float]) -> dict[str, FloatArray]:
    """Percentiles (len(percentiles), T) of each metric's (n, T) values over the runs with
    ``ok`` where the metric is defined (not NaN); NaN where no such run is."""
    table: dict[str, FloatArray] = {}
    every = bool(np.all(ok))
    for name, array in values.items():
        good = array if every else array[ok]
        defined = ~np.isnan(good)
        result = np.full((len(percentiles), array.shape[1]), np.nan)
        if bool(np.all(defined)) and good.shape[0]:
            result = np.percentile(good, list(percentiles), axis=0)
        else:
            for column in np.flatnonzero(np.any(defined, axis=0)):
                result[:, column] = np.percentile(good[defined[:, column], column],
                                                  list(percentiles))
        table[name] = result
    return table
