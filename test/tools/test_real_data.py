"""Real IMU data: BROAD trials replayed through the strapdown scene against optical truth.

Data: D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD — A Benchmark for Robust Inertial
Orientation Estimation", Data 6(7):72, 2021, doi:10.3390/data6070072, licence CC BY 4.0. The
converted bags carry this attribution in their metadata (``broad.trial_to_bag``) and the
replay's output bag keeps it.

Each trial becomes a bag (``sensor_msgs/Imu`` on ``imu``, ``geometry_msgs/QuaternionStamped``
on ``ground_truth``). The replay uses a strapdown scene whose ``gyro_bias`` effect averages the
initial rest phase (every sample before the first motion sample) and starts from the ground
truth at the first motion sample (``--start-from-ground-truth``). The attitude error against
the ground truth is then gyro-limited: with 77 rad of rotation in the first 10 s of trial 07
(25 rad/s peaks), a scale-factor or axis-misalignment error of 0.1–0.2 % — typical of MEMS
gyros — gives 4–9°, and the higher-order update (trapezoid + coning term) removes only the
integrator's share (Savage, "Strapdown inertial navigation integration algorithm design, part 1:
attitude algorithms", JGCD 21(1), 1998). Our measurements (deterministic: same data, same code):

========  ================  ==================  ==================
trial     method            max error, 10 s      max error, whole
========  ================  ==================  ==================
07        exp_map           8.875°               9.357°
07        trapezoid_coning  6.521°               7.407°
15        exp_map           1.332°               7.269°
15        trapezoid_coning  1.033°               6.519°
========  ================  ==================  ==================

(the issue quotes about 9.2 / 6.9° and 1.3 / 1.0° for the first 10 s; ``test_broad.py``
explains the set-up details behind the small difference on trial 07). The bounds asserted are
the measurement plus 3 %: a regression in the replay, the stream rules or a method shows, while
the figures may move by round-off only. The converted trials start at stamp 0.0; the node (and
so the replay) refuses that first sample as unstamped (``zero_stamp``), so the rest-phase
average has one sample fewer than the trial (the figures moved by at most 0.01° when the
replay moved onto the node's session).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from rigid_body_attitude.tools import broad
from rigid_body_attitude.bag import BagReader
from rigid_body_attitude.tools.replay import ReplayOptions, replay_bag

TRIAL_07 = '07_undisturbed_fast_rotation_B'
TRIAL_15 = '15_undisturbed_fast_translation_A'
WINDOW_NS = 10 * 10**9
#: Methods of the real-data table, when the propagator offers them (methods.strapdown_method).
METHODS = ('exp_map', 'trapezoid_coning')
#: Measured max errors [deg] (first 10 s, whole trial) per trial and method; see the table.
MEASURED_DEG = {
    (TRIAL_07, 'exp_map'): (8.875, 9.357),
    (TRIAL_07, 'trapezoid_coning'): (6.521, 7.407),
    (TRIAL_15, 'exp_map'): (1.332, 7.269),
    (TRIAL_15, 'trapezoid_coning'): (1.033, 6.519),
}
MARGIN = 1.03


def strapdown_scene(path: Path, method: str, trial: broad.BroadTrial) -> Path:
    """A strapdown scene averaging the gyro over the rest phase (all samples before motion)."""
    motion_stamp = trial.first_motion_index / trial.sampling_rate
    scene = {
        'name': f'broad_{method}',
        'rate_source': 'gyro',
        'integrator': method,
        'body': {'mass': 1.0, 'inertia': {'moments': [1.0, 1.0, 1.0]}},
        # Half a sample short of the first motion stamp: the last rest sample is inside, the
        # first motion sample outside, whatever the rounding of the stamps.
        'effects': [{'gyro_bias': {
            'estimate_seconds': motion_stamp - 0.5 / trial.sampling_rate}}],
    }
    path.write_text(yaml.safe_dump(scene), encoding='utf-8')
    return path


def replay_trial(trial: broad.BroadTrial, bag: Path, method: str, workdir: Path):
    """Replay the trial's bag with ``method`` from the ground truth at the first motion."""
    scene = strapdown_scene(workdir / f'{method}.yaml', method, trial)
    motion_stamp = trial.first_motion_index / trial.sampling_rate
    options = ReplayOptions(scene=str(scene), ground_truth_topic='ground_truth',
                            start_from_ground_truth=motion_stamp, outputs=('orientation',))
    return replay_bag(bag, workdir / f'out_{method}', options)


@pytest.mark.parametrize('trial_name', [TRIAL_07, TRIAL_15])
def test_real_data_error_stays_within_the_measured_gyro_limited_bound(trial_name, data_dir,
                                                                      tmp_path):
    trial = broad.load_trial(data_dir / f'{trial_name}.npz')
    bag = tmp_path / 'trial'
    counts = broad.trial_to_bag(trial, bag)
    methods = list(METHODS)
    assert 'exp_map' in methods
    first_window = {}
    for method in methods:
        result = replay_trial(trial, bag, method, tmp_path)
        # Started at the first motion sample, from the ground truth there.
        motion_ns = round(trial.first_motion_index / trial.sampling_rate * 1e9)
        assert result.alignment_stamp_ns == motion_ns
        assert result.read['imu'] == counts['imu'] == trial.sample_count
        # The first sample is stamped 0.0: the node refuses a zero stamp (unstamped input).
        assert +result.rejected == {'zero_stamp': 1}
        errors = result.errors.within(motion_ns, 10**20)
        first = errors.within(motion_ns, motion_ns + WINDOW_NS)
        # Every ground-truth sample of the motion phase is compared (lost ones are absent).
        expected = int(np.sum(~trial.ground_truth_lost[trial.first_motion_index:]))
        assert errors.count == expected
        assert errors.errors[0] == pytest.approx(0.0, abs=1e-12)
        first_deg = float(np.degrees(first.errors.max()))
        whole_deg = float(np.degrees(errors.errors.max()))
        measured_first, measured_whole = MEASURED_DEG[(trial_name, method)]
        assert first_deg <= MARGIN * measured_first, (method, first_deg)
        assert whole_deg <= MARGIN * measured_whole, (method, whole_deg)
        # Not a vacuous bound: the figure is the measured one (the run is deterministic).
        assert first_deg == pytest.approx(measured_first, abs=1e-3)
        first_window[method] = first_deg
        print(f'{trial_name} {method}: max error {first_deg:.3f} deg in 10 s, '
              f'{whole_deg:.3f} deg over the trial')
    if trial_name == TRIAL_07 and 'trapezoid_coning' in first_window:
        assert first_window['trapezoid_coning'] < first_window['exp_map']
    # The output bag keeps the dataset's attribution (CC BY 4.0) from the input bag.
    with BagReader(result.output_path) as reader:
        custom = reader.custom_data
    assert custom['license'].startswith('CC BY 4.0')
    assert 'doi:10.3390/data6070072' in custom['citation']
    assert custom['replay_scene'] == f'broad_{methods[-1]}'
