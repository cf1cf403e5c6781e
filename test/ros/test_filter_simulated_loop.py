"""The two halves check each other with the updates on: a dynamics node's simulated IMU and
magnetometer feed the attitude filter over ROS, for a minute of tumbling.

Two installed ``propagation_node`` processes: a dynamics node (a tumbling box, ``sensors``
with an IMU at 200 Hz feeling gravity and a magnetometer at 100 Hz in the local field, both
in ``imu_link`` mounted at yaw 1 rad) in ``/sim`` following ``/clock``, and the filter
(``imu_filter`` scene) in ``/sim/est`` on ``/sim/imu`` and ``/sim/imu/mag`` with the
simulated sensors' noise figures as parameters and the mount from the dynamics node's
``/tf_static``. The body starts at the identity, as the filter does (``align_seconds`` 0, the
start known to ``initial_yaw_stddev``). The test publishes ``/clock`` in steps of 5 ms and
waits for the truth's ``orientation`` before the next step. Every second, the filter's error
against the truth, ``δθ = log(q_true ⊗ q_est*)`` (world axes), and its published covariance
give the NEES ``δθᵀ P⁻¹ δθ`` (3 dof): inside the chi-square 99 % bound at 93 % of the checks
at least, its mean over the minute inside the two-sided 99 % band of ``χ²(3·60)/60`` (a
covariance ten times too large falls below it).
"""

from __future__ import annotations

from collections.abc import Iterator

from geometry_msgs.msg import PoseWithCovarianceStamped, QuaternionStamped
import numpy as np
import pytest
from rosgraph_msgs.msg import Clock
from ros_helpers import Harness, ros_session, RosContext, stamp
from scipy.stats import chi2
import yaml

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.ros.serve import SERVING_LINE

from test_node_subprocess import read_until, start, stop_with_sigint

PERIOD_NS = 5_000_000
START_NS = 1000 * 10**9
SECONDS = 60
GYRO = {'gyroscope_noise_density': 1e-3, 'gyroscope_random_walk': 1e-4,
        'gyroscope_turn_on_bias': 0.005, 'gyroscope_scale_stddev': 0.003,
        'gyroscope_misalignment_stddev': 0.003}
ACCEL = {'accelerometer_noise_density': 2e-3}
FIELD_NOISE = 1e-7
BOUND = chi2.ppf(0.99, 3)


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    with ros_session(ros_domain_id) as session:
        yield session


def scene_file(tmp_path):
    path = tmp_path / 'sensed.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'sensed', 'rate_source': 'dynamics', 'step': 0.001,
        'body': {'mass': 2.0, 'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': [0.3, 0.5, -0.4]},
        'sensors': {
            'imu': {'rate': 200.0, 'frame_id': 'imu_link', 'seed': 3,
                    'mount_rpy': [0.0, 0.0, 1.0], 'gravity': [0.0, 0.0, -9.80665],
                    **GYRO, **ACCEL},
            'magnetometer': {'rate': 100.0, 'frame_id': 'imu_link', 'seed': 3,
                             'mount_rpy': [0.0, 0.0, 1.0], 'noise_density': FIELD_NOISE,
                             'intensity': 5.0e-5, 'inclination': 1.1, 'declination': 0.0}}}))
    return str(path)


def stamp_ns(message):
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def wxyz(q):
    return np.array([q.w, q.x, q.y, q.z])


def test_the_filter_over_ros_on_simulated_sensors_is_consistent(ros, processes, tmp_path):
    dynamics = start('--ros-args', '-p', f'scene:={scene_file(tmp_path)}',
                     '-p', 'publish_rate:=200.0', '-p', 'use_sim_time:=true', '-r', '__ns:=/sim')
    figures = {**GYRO, **ACCEL, 'magnetometer_noise_density': FIELD_NOISE}
    estimator = start('--ros-args', '-p', 'scene:=imu_filter', '-p', 'align_seconds:=0.0',
                      '-p', 'initial_yaw_stddev:=0.001',
                      *[arg for name, value in figures.items()
                        for arg in ('-p', f'{name}:={value!r}')],
                      '-r', '__ns:=/sim/est', '-r', 'imu:=/sim/imu', '-r', 'imu/mag:=/sim/imu/mag')
    processes += [dynamics, estimator]
    read_until(dynamics, SERVING_LINE, 60.0)
    read_until(estimator, SERVING_LINE, 60.0)
    harness = Harness(ros, '/')
    truth = harness.record(QuaternionStamped, '/sim/orientation')
    estimates = harness.record(QuaternionStamped, '/sim/est/orientation')
    covariances = harness.record(PoseWithCovarianceStamped, '/sim/est/pose_with_covariance')
    clock = harness.publisher(Clock, '/clock')
    harness.wait_for_connections(60.0)
    assert harness.spin_until(lambda: clock.get_subscription_count() >= 1, 60.0)
    for k in range(int(SECONDS * 1e9 / PERIOD_NS) + 2):
        now = START_NS + k * PERIOD_NS
        for _ in range(5):  # /clock is volatile: a tick missed by a late reader is resent
            clock.publish(Clock(clock=stamp(now)))
            if harness.spin_until(lambda: truth and stamp_ns(truth[-1]) >= now and (
                    k < 2 or (estimates and stamp_ns(estimates[-1]) >= now - PERIOD_NS)), 2.0):
                break
        else:
            raise AssertionError(f'no truth at {now} ns')
    last = START_NS + SECONDS * 10**9
    assert harness.spin_until(lambda: covariances and stamp_ns(covariances[-1]) >= last, 20.0)
    for process in (dynamics, estimator):
        code, stderr = stop_with_sigint(process)
        assert code == 0 and 'Traceback' not in stderr, stderr
    true_at = {stamp_ns(m): wxyz(m.quaternion) for m in truth}
    est_at = {stamp_ns(m): wxyz(m.quaternion) for m in estimates}
    cov_at = {stamp_ns(m): np.reshape(m.pose.covariance, (6, 6))[3:, 3:] for m in covariances}
    checks = [START_NS + s * 10**9 for s in range(1, SECONDS + 1)]
    nees = []
    for at in checks:
        error = quaternion.log(quaternion.multiply(true_at[at], quaternion.conjugate(est_at[at])))
        p = cov_at[at]
        nees.append((float(error @ np.linalg.solve(p, error)),
                     float(error @ np.linalg.solve(10.0 * p, error)),
                     float(np.degrees(np.linalg.norm(error))),
                     float(error[:2] @ np.linalg.solve(p[:2, :2], error[:2])),
                     float(error[2] ** 2 / p[2, 2])))
    values = np.array(nees)
    inside = float(np.mean(values[:, 0] <= BOUND))
    print(f'NEES over {SECONDS} s: inside the 99 % bound {100 * inside:.1f} %, mean '
          f'{values[:, 0].mean():.2f} (tilt {values[:, 3].mean():.2f} of 2, heading '
          f'{values[:, 4].mean():.2f} of 1), largest error {values[:, 2].max():.3f} deg')
    assert inside >= 0.93
    band = chi2.ppf([0.005, 0.995], 3 * SECONDS) / SECONDS
    assert band[0] <= values[:, 0].mean() <= band[1], (band, values[:, 0].mean())
    assert not band[0] <= values[:, 1].mean() <= band[1]
