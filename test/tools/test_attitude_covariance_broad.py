"""The attitude covariance on real data: BROAD trials against their optical truth.

Harness in :mod:`broad_coverage` (levelling over 1 s, rest-phase bias, noise densities from the
trial's own rest phase, documented defaults for everything else, nothing tuned per trial).
With the full error budget the tilt error lies inside its 3σ bound at least 95 % of the time on
every trial; with white noise alone it does not on the fast-rotation trial. The 1σ tilt stays
below 10° in median (the defaults' 1 % scale and 1.25 % cross-axis priors at BROAD's up to
25 rad/s give 8-9° on the fast trials: an honest bound, if a wide one).

Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel. "BROAD — A Benchmark for Robust Inertial
Orientation Estimation". Data 6(7):72, 2021. doi:10.3390/data6070072 (CC BY 4.0).
"""

from __future__ import annotations

import pytest

import broad_coverage

PATHS = broad_coverage.trial_paths()


@pytest.fixture(scope='module')
def figures() -> dict[tuple[str, bool], broad_coverage.Coverage]:
    """Coverage of every trial, full budget (False) and white noise alone (True)."""
    return {(path.stem, white): broad_coverage.coverage(path, white_noise_only=white)
            for path in PATHS for white in (False, True)}


def test_the_shipped_trials_are_all_evaluated(figures):
    assert {'07_undisturbed_fast_rotation_B', '15_undisturbed_fast_translation_A'} <= {
        name for name, _ in figures}
    assert all(figure.evaluated > 1000 for figure in figures.values())


@pytest.mark.parametrize('path', PATHS, ids=[path.stem for path in PATHS])
def test_the_tilt_error_is_inside_3_sigma_95_percent_of_the_time(figures, path):
    figure = figures[(path.stem, False)]
    assert figure.inside_3_sigma >= 0.95, figure
    assert figure.median_tilt_sigma_deg < 10.0, figure


def test_white_noise_alone_is_not_an_honest_bound_on_the_fast_rotation_trial(figures):
    figure = figures[('07_undisturbed_fast_rotation_B', True)]
    assert figure.inside_3_sigma < 0.95, figure
