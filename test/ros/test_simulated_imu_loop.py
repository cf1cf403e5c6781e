"""The two halves of the package check each other over ROS: a dynamics node's simulated IMU
feeds a strapdown node, and the strapdown error against the dynamics truth is consistent with
the covariance the strapdown node publishes (the NEES test of the covariance, now end to end).

Four runs at once, each a pair of installed ``propagation_node`` processes: a dynamics node
(a tumbling body, ``sensors.imu`` at 200 Hz with seed r, mount yaw 1 rad) in namespace ``/rN``
following ``/clock`` (``use_sim_time``), and a strapdown node in ``/rN/est`` subscribed to
``/rN/imu``, with the same noise figures as parameters and the mount from the dynamics node's
``/tf_static``. The test publishes ``/clock`` in steps of 5 ms and waits for every truth
``orientation`` before the next step, so each tick and each sample is at a multiple of 5 ms
and every run is the same on any machine. Each IMU's bias, scale factors and misalignment are
drawn from the priors the strapdown covariance assumes. The strapdown starts at the identity
at its first sample; the truth is taken relative to the body at that instant. At 2 s and 4 s
after it, the mean over runs of ``δθᵀ P⁻¹ δθ`` (3 dof, world axes) must lie in the two-sided
95 % band of ``χ²(3 R)/R``; the same check with the covariance ten times too large must fail.
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

RUNS = 4
PERIOD_NS = 5_000_000
START_NS = 1000 * 10**9
CHECKS_S = (2.0, 4.0)
FIGURES = {'gyroscope_noise_density': 1e-3, 'gyroscope_random_walk': 1e-4,
           'gyroscope_turn_on_bias': 0.005, 'gyroscope_scale_stddev': 0.003,
           'gyroscope_misalignment_stddev': 0.003}
BAND = (chi2.ppf(0.025, 3 * RUNS) / RUNS, chi2.ppf(0.975, 3 * RUNS) / RUNS)


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    with ros_session(ros_domain_id) as session:
        yield session


def scene_file(tmp_path, seed):
    path = tmp_path / f'sensed_{seed}.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'sensed', 'rate_source': 'dynamics', 'step': 0.001,
        'body': {'mass': 2.0, 'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': [0.3, 0.5, -0.4]},
        'sensors': {'imu': {'rate': 200.0, 'frame_id': 'imu_link', 'seed': seed,
                            'mount_rpy': [0.0, 0.0, 1.0], **FIGURES}}}))
    return str(path)


def start_pair(tmp_path, run, processes):
    dynamics = start('--ros-args', '-p', f'scene:={scene_file(tmp_path, run)}',
                     '-p', 'publish_rate:=200.0', '-p', 'use_sim_time:=true',
                     '-r', f'__ns:=/r{run}')
    strapdown = start('--ros-args', '-p', 'scene:=strapdown', '-p', 'align_seconds:=0.0',
                      '-p', 'initial_yaw_stddev:=0.0001',
                      *[arg for name, value in FIGURES.items()
                        for arg in ('-p', f'{name}:={value!r}')],
                      '-r', f'__ns:=/r{run}/est', '-r', f'imu:=/r{run}/imu')
    processes += [dynamics, strapdown]
    return dynamics, strapdown


def stamp_ns(message):
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def wxyz(q):
    return np.array([q.w, q.x, q.y, q.z])


def drive_clock(harness, truths, seconds):
    """/clock in 5 ms steps; each step waits for every run's truth at that time."""
    clock = harness.publisher(Clock, '/clock')
    for k in range(int(seconds * 1e9 / PERIOD_NS) + 1):
        now = START_NS + k * PERIOD_NS
        # /clock is volatile: a tick a node's reader missed (matched late on a loaded
        # machine) is sent again, up to 10 s in all.
        for _ in range(5):
            clock.publish(Clock(clock=stamp(now)))
            if harness.spin_until(lambda: all(
                    truth and stamp_ns(truth[-1]) >= now for truth in truths), 2.0):
                break
        else:
            raise AssertionError(f'no truth at {now} ns from every dynamics node')


def nees_at_checks(truth, estimates, covariances):
    """Per check: (δθ, P) of one run (world axes of the strapdown's start)."""
    true_at = {stamp_ns(m): wxyz(m.quaternion) for m in truth}
    est_at = {stamp_ns(m): wxyz(m.quaternion) for m in estimates}
    cov_at = {stamp_ns(m): np.reshape(m.pose.covariance, (6, 6))[3:, 3:] for m in covariances}
    first = min(est_at)
    assert np.allclose(est_at[first], [1.0, 0.0, 0.0, 0.0], atol=1e-12)
    anchor = quaternion.conjugate(true_at[first])
    rows = []
    for check in CHECKS_S:
        at = first + round(check * 1e9)
        true = quaternion.multiply(anchor, true_at[at])
        error = quaternion.log(quaternion.multiply(true, quaternion.conjugate(est_at[at])))
        rows.append((error, cov_at[at]))
    return rows


def test_strapdown_error_over_ros_is_consistent_with_its_covariance(ros, request, processes,
                                                                    tmp_path):
    pairs = [start_pair(tmp_path, run, processes) for run in range(RUNS)]
    for dynamics, strapdown in pairs:
        read_until(dynamics, SERVING_LINE, 60.0)
        read_until(strapdown, SERVING_LINE, 60.0)
    harness = Harness(ros, '/')
    truths = [harness.record(QuaternionStamped, f'/r{run}/orientation') for run in range(RUNS)]
    estimates = [harness.record(QuaternionStamped, f'/r{run}/est/orientation')
                 for run in range(RUNS)]
    covariances = [harness.record(PoseWithCovarianceStamped,
                                  f'/r{run}/est/pose_with_covariance') for run in range(RUNS)]
    clock = harness.publisher(Clock, '/clock')
    harness.wait_for_connections(60.0)
    assert harness.spin_until(lambda: clock.get_subscription_count() >= RUNS, 60.0), (
        f'/clock read by {clock.get_subscription_count()} of the {RUNS} dynamics nodes')
    duration = max(CHECKS_S) + 0.1
    drive_clock(harness, truths, duration)
    last = START_NS + round(max(CHECKS_S) * 1e9)
    assert harness.spin_until(lambda: all(
        c and stamp_ns(c[-1]) >= last for c in covariances), 20.0)
    for dynamics, strapdown in pairs:
        for process in (dynamics, strapdown):
            code, stderr = stop_with_sigint(process)
            assert code == 0 and 'Traceback' not in stderr, stderr
    table = [nees_at_checks(*runs) for runs in zip(truths, estimates, covariances)]
    mean_nees, too_large = [], []
    for index in range(len(CHECKS_S)):
        rows = [run[index] for run in table]
        mean_nees.append(np.mean([e @ np.linalg.solve(p, e) for e, p in rows]))
        too_large.append(np.mean([e @ np.linalg.solve(10.0 * p, e) for e, p in rows]))
    print(f'mean NEES at {CHECKS_S} s: {mean_nees}; 95 % band {BAND}')
    assert all(BAND[0] <= value <= BAND[1] for value in mean_nees), (BAND, mean_nees)
    assert not any(BAND[0] <= value <= BAND[1] for value in too_large), (BAND, too_large)
