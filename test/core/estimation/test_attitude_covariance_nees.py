"""Monte-Carlo consistency of the attitude covariance: the NEES test and its negative controls.

400 runs (:mod:`gyro_simulation`, generated without the covariance code) with gyro white noise,
a walking bias, scale-factor and misalignment errors and an initial attitude error drawn from
the priors, on a body turning at several rad/s about changing axes for 20 s. Each run carries
its own :class:`AttitudeCovariance` along its own estimate. At 5, 10, 15 and 20 s the mean over
runs of the NEES ``δθᵀ P⁻¹ δθ`` (3 dof) must lie in the two-sided 95 % band of
``χ²(3 N)/N``. The same check must fail for the covariance doubled, for the covariance taken
about body axes instead of world axes, and for a filter without the scale-factor term.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.attitude_covariance import AttitudeCovariance
from rigid_body_attitude.core.estimation.gyro_error_model import GyroErrorModel, initial_covariance

import gyro_simulation as sim

RUNS = 400
DURATION = 20.0
CHECKS = 4
#: A fold every half second: the transition is exact for any batch (tested below).
BATCH = 50
MODEL = GyroErrorModel(gyroscope_noise_density=2.4e-4, gyroscope_random_walk=1e-4,
                       gyroscope_scale_stddev=0.003, gyroscope_misalignment_stddev=0.003,
                       accelerometer_bias_stddev=0.0087 * 9.80665, initial_yaw_stddev=0.05)
NO_SCALE = GyroErrorModel(**{**MODEL.__dict__, 'gyroscope_scale_stddev': 0.0})
BAND = (chi2.ppf(0.025, 3 * RUNS) / RUNS, chi2.ppf(0.975, 3 * RUNS) / RUNS)


def mean_nees(errors: np.ndarray, covariances: np.ndarray) -> float:
    """Mean over runs of ``δθᵀ P⁻¹ δθ``."""
    return float(np.mean(np.einsum('ri,rij,rj->r', errors, np.linalg.inv(covariances),
                                   errors)))


@pytest.fixture(scope='module')
def nees_table() -> dict[str, list[float]]:
    """Mean NEES at each check time for the filter and the three controls."""
    steps = int(DURATION * sim.SAMPLE_RATE)
    segment = steps // CHECKS
    motion = sim.shared_motion(steps)
    start = initial_covariance(MODEL, 1.0)
    runs = sim.draw_runs(RUNS, start, seed=20261126)
    filters = [AttitudeCovariance(MODEL, covariance=start, batch_size=BATCH)
               for _ in range(RUNS)]
    no_scale = [AttitudeCovariance(NO_SCALE, covariance=initial_covariance(NO_SCALE, 1.0),
                                   batch_size=BATCH) for _ in range(RUNS)]
    table: dict[str, list[float]] = {'filter': [], 'doubled': [], 'body_axes': [],
                                     'no_scale': []}
    for check in range(CHECKS):
        q_starts, rates = sim.advance(runs, check * segment, segment,
                                      MODEL.gyroscope_noise_density,
                                      MODEL.gyroscope_random_walk)
        for run in range(RUNS):
            filters[run].add_samples(q_starts[:, run], rates[:, run], 1.0 / sim.SAMPLE_RATE)
            no_scale[run].add_samples(q_starts[:, run], rates[:, run], 1.0 / sim.SAMPLE_RATE)
        errors = sim.world_errors(runs, motion[(check + 1) * segment])
        world = np.array([f.attitude_covariance for f in filters])
        rotation = quaternion.to_matrix(runs.q_est)
        body = np.transpose(rotation, (0, 2, 1)) @ world @ rotation
        table['filter'].append(mean_nees(errors, world))
        table['doubled'].append(mean_nees(errors, 2.0 * world))
        table['body_axes'].append(mean_nees(errors, body))
        table['no_scale'].append(mean_nees(errors, np.array([f.attitude_covariance
                                                             for f in no_scale])))
    return table


def inside(values: list[float]) -> list[bool]:
    """Whether each mean NEES lies in the 95 % band."""
    return [BAND[0] <= value <= BAND[1] for value in values]


def test_mean_nees_is_inside_the_95_percent_band_at_every_check(nees_table):
    assert all(inside(nees_table['filter'])), (BAND, nees_table['filter'])


@pytest.mark.parametrize('control', ['doubled', 'body_axes', 'no_scale'])
def test_negative_control_fails_the_same_check(nees_table, control):
    assert not any(inside(nees_table[control])), (BAND, nees_table[control])


def test_the_error_is_large_enough_for_the_controls_to_matter(nees_table):
    """The scale-factor term and the axes matter: their controls miss by more than 2x."""
    assert min(nees_table['no_scale'][1:]) > 2.0 * BAND[1]
    assert min(nees_table['body_axes']) > 1.5 * BAND[1]
