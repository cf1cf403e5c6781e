"""The whole GNC loop over ROS: plant, estimator and controller, three processes in lockstep.

The installed ``propagation_node`` on ``star_tracker_pointing`` (``lockstep``,
``real_time_factor`` 0, 100 Hz ticks) is the plant and the graph's clock: a 20 kg satellite on
four reaction wheels, its simulated gyro (``imu``, 100 Hz) and star tracker
(``star_tracker``, 10 Hz, 5 and 35 arcsec). A second ``propagation_node`` on
``star_tracker_filter`` in ``<ns>/est`` is the estimator: gyro strapdown corrected by the star
tracker (``imu`` and ``attitude_measurement`` remapped to the plant's), started from the first
star tracker sample, the gyro's noise figures as parameters; it publishes ``odom`` per gyro
sample. The installed ``attitude_controller`` (``actuator`` ``reaction_wheels``, ``odom``
remapped to the estimator's) answers each estimate with the wheels' motor torques, stamped
like it: the plant waits for them before the next tick, so the command of tick ``k`` is
computed on the estimate stamped ``t_k`` (the gyro sample of ``t_k`` and the star tracker
samples stamped before it).

60 s of sim time (6001 ticks), run twice: the estimates and the wheel commands are the same
bit for bit, and the same as the in-process loop of the three sessions (``test/gnc_loop.py``,
the star tracker's samples handed to the estimator after the gyro's of their instant). Every
second the estimate's error against the plant's truth, ``δθ = log(q_true ⊗ q_est*)`` (world
axes), and the estimator's published covariance give the NEES ``δθᵀ P⁻¹ δθ`` (3 dof): inside
the chi-square 99 % bound at 93 % of the checks at least, its mean over the minute inside the
two-sided 99 % band of ``χ²(3·60)/60``. The pointing budget over the last 30 s, printed: the
estimation error (truth against estimate), the control error (estimate against target) and
the pointing error (truth against target), RMS and largest.
"""

from __future__ import annotations

from collections.abc import Iterator

from controller_process import parameter_arguments, start_controller, stop_controller
from geometry_msgs.msg import QuaternionStamped
from gnc_loop import CONTROLLER, estimator_values, gnc_loop, TARGET_RPY, TICK_RATE
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_helpers import Harness, ros_session, RosContext, unique_namespace
from scipy.stats import chi2
from sensor_msgs.msg import JointState
from test_node_subprocess import read_until, SERVING, start, stop_with_sigint

from rigid_body_attitude.core.attitude import quaternion

TICK_NS = round(1e9 / TICK_RATE)
SECONDS = 60
TICKS = SECONDS * round(TICK_RATE) + 1
BOUND = chi2.ppf(0.99, 3)
SETTLED_NS = 30 * 10**9
LATCHED = QoSProfile(depth=10000, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    with ros_session(ros_domain_id) as session:
        yield session


def stamp_ns(message) -> int:
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def ros_loop(ros, namespace: str) -> tuple[dict, dict, dict, dict]:
    """One run: by stamp, the truth, the estimate, its covariance, the wheel command."""
    harness = Harness(ros, namespace)
    truth = harness.record(QuaternionStamped, 'orientation')
    odometry = harness.record(Odometry, 'est/odom')
    plant = start('--ros-args', '-r', f'__ns:={namespace}', '-p', 'scene:=star_tracker_pointing',
                  '-p', 'lockstep:=true', '-p', f'publish_rate:={TICK_RATE}',
                  '-p', 'real_time_factor:=0.0', '-p', 'lockstep_timeout:=60.0')
    reliable = {f'qos_overrides.{namespace}/{topic}.subscription.reliability': 'reliable'
                for topic in ('imu', 'star_tracker')}
    estimator = start('--ros-args', '-r', f'__ns:={namespace}/est',
                      '-r', f'imu:={namespace}/imu',
                      '-r', f'attitude_measurement:={namespace}/star_tracker',
                      *parameter_arguments({**estimator_values(), **reliable}))
    controller = None
    try:
        read_until(plant, SERVING)
        read_until(estimator, SERVING)
        harness.wait_for_connections(30.0)  # tick 0 repeats until the controller answers
        # the controller's writer is transient local: its first commands reach a late reader
        commands = harness.record(JointState, 'wheels/command', LATCHED)
        controller = start_controller(namespace, CONTROLLER, '-r', f'odom:={namespace}/est/odom')
        harness.wait_for_connections(30.0)
        last = (TICKS - 1) * TICK_NS
        done = harness.spin_until(lambda: bool(truth) and stamp_ns(truth[-1]) >= last and bool(
            odometry) and stamp_ns(odometry[-1]) >= last and bool(commands) and stamp_ns(
            commands[-1]) >= last, timeout=240.0)
    finally:
        stopped = [stop_with_sigint(process) for process in (plant, estimator)]
        controller_errors = stop_controller(controller)
    assert done, (f'{len(truth)} ticks recorded', stopped[0][1][-3000:], stopped[1][1][-3000:],
                  controller_errors[-3000:])
    for code, stderr in stopped:
        assert code == 0 and 'Traceback' not in stderr, stderr
    assert 'lockstep: no command stamped' not in stopped[0][1].split('SIGINT')[0]
    true_at = {stamp_ns(m): (m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z)
               for m in truth}
    estimate_at, covariance_at = {}, {}
    for message in odometry:
        q = message.pose.pose.orientation
        estimate_at[stamp_ns(message)] = (q.w, q.x, q.y, q.z)
        covariance_at[stamp_ns(message)] = np.reshape(message.pose.covariance, (6, 6))[3:, 3:]
    command_at = {stamp_ns(m): tuple(m.effort) for m in commands}
    for series in (true_at, estimate_at, command_at):
        assert all(k * TICK_NS in series for k in range(TICKS))
    return true_at, estimate_at, covariance_at, command_at


def angles(pairs) -> np.ndarray:
    """The rotation angles [rad] between the attitudes of each pair."""
    return np.array([quaternion.attitude_error(np.array(a), np.array(b)) for a, b in pairs])


def arcsec(values: np.ndarray | tuple[np.ndarray, np.ndarray]) -> str:
    """RMS and largest [arcsec] of ``values`` [rad] (of a pair: the sums of each)."""
    if isinstance(values, tuple):
        rms = sum(np.sqrt(np.mean(part ** 2)) for part in values)
        largest = sum(np.max(part) for part in values)
    else:
        rms, largest = np.sqrt(np.mean(values ** 2)), np.max(values)
    return f'{np.degrees(rms) * 3600:.1f} rms, {np.degrees(largest) * 3600:.1f} largest'


def test_the_gnc_loop_is_reproducible_consistent_and_points(ros, request, capsys):
    truth, estimates, covariances, commands = ros_loop(ros, unique_namespace(request))
    again = ros_loop(ros, unique_namespace(request) + '_again')
    stamps = [k * TICK_NS for k in range(TICKS)]
    assert [estimates[at] for at in stamps] == [again[1][at] for at in stamps]
    assert [commands[at] for at in stamps] == [again[3][at] for at in stamps]
    local = gnc_loop(SECONDS, star_first=False)
    assert [local.estimates[at] for at in stamps] == [estimates[at] for at in stamps]
    assert [local.commands[at] for at in stamps] == [commands[at] for at in stamps]
    nees = []
    for second in range(1, SECONDS + 1):
        at = second * 10**9
        error = quaternion.log(quaternion.multiply(np.array(truth[at]), quaternion.conjugate(
            np.array(estimates[at]))))
        nees.append(float(error @ np.linalg.solve(covariances[at], error)))
    values = np.array(nees)
    inside = float(np.mean(values <= BOUND))
    band = chi2.ppf([0.005, 0.995], 3 * SECONDS) / SECONDS
    target = tuple(quaternion.from_rpy(TARGET_RPY).tolist())
    settled = [at for at in stamps if at >= SETTLED_NS]
    estimation = angles((truth[at], estimates[at]) for at in settled)
    control = angles((estimates[at], target) for at in settled)
    pointing = angles((truth[at], target) for at in settled)
    start = angles([(truth[0], target)])[0]
    with capsys.disabled():
        print(f'\nGNC loop over ROS, {SECONDS} s: NEES inside the 99 % bound '
              f'{100 * inside:.1f} %, mean {values.mean():.2f} (band {band[0]:.2f}-'
              f'{band[1]:.2f}); from {np.degrees(start):.1f} deg off, over 30-60 s [arcsec]: '
              f'estimation {arcsec(estimation)}; control {arcsec(control)}; pointing '
              f'{arcsec(pointing)}; estimation + control {arcsec((estimation, control))} '
              f'(the sum of each)')
    assert inside >= 0.93
    assert band[0] <= values.mean() <= band[1], (band, values.mean())
    assert np.degrees(start) > 20.0
    assert np.degrees(np.max(pointing)) * 3600 < 120.0
