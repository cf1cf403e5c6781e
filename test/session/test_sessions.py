"""The sessions without ROS: every hostile or faulty input is rejected, counted, warned about,
and never reaches the sink as a non-finite value; diagnostics say what happened.

These are the node's rules, tested in milliseconds; test/ros/ checks that the node feeds them.
"""

import math

import numpy as np
import pytest
from conftest import BASE_NS, MS

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.session.reports import LEVEL_ERROR, LEVEL_OK, LEVEL_WARN

OMEGA = (0.0, 0.0, 2.0)


def split(nanoseconds):
    return divmod(nanoseconds, 10**9)


def feed(session, count, start_ns=BASE_NS, period_ns=MS, rate=OMEGA):
    for k in range(count):
        session.gyro(*split(start_ns + k * period_ns), rate)


def finite_outputs(sink):
    values = [v for _, _, attitude in sink.attitudes for v in attitude]
    for _, _, sample, velocity in sink.ticks:
        values += [*sample.attitude, *sample.position, *sample.omega_body, sample.energy,
                   *sample.world_momentum, *velocity]
    values += [v for _, _, energy, momentum in sink.invariant_samples
               for v in (energy, *momentum)]
    return all(math.isfinite(v) for v in values)


def test_a_clean_gyro_stream_reports_ok_with_accepted_inputs(open_scene, clocks):
    session, sink = open_scene('strapdown', tilt_stddev_warn=0.0)  # unlevelled: tilt unknown
    feed(session, 1000)
    clocks.monotonic = 1.0
    report = session.report()
    values = dict(report.values)
    assert (report.level, report.message) == (LEVEL_OK, 'propagating')
    assert values['accepted'] == '1000' and values['input_rate [Hz]'] == '1000.0'
    assert len(sink.attitudes) == 1000
    expected = quaternion.exp(np.array(OMEGA) * 0.999)
    assert quaternion.attitude_error(sink.attitudes[-1][2], expected) <= 1e-12


@pytest.mark.parametrize('sec, nanosec, reason', [
    (1_700_000_000, 1_000_000_000, 'invalid_stamp'),
    (1_700_000_000, 4_294_967_295, 'invalid_stamp'),
    (-5, 0, 'invalid_stamp'),
    (0, 0, 'zero_stamp'),
])
def test_invalid_and_zero_stamps_are_rejected(open_scene, sec, nanosec, reason):
    session, sink = open_scene('strapdown')
    feed(session, 10)
    assert not session.gyro(sec, nanosec, OMEGA)
    feed(session, 10, BASE_NS + 10 * MS)
    assert session.rejection_counts()[reason] == 1 and len(sink.attitudes) == 20
    assert session.stream.rejected == {}  # the stream never saw it: nothing disturbed


def test_a_lone_stamp_far_in_the_future_changes_nothing(open_scene):
    session, sink = open_scene('strapdown')
    feed(session, 10)
    session.gyro(2**31 - 1, 0, OMEGA)
    feed(session, 10, BASE_NS + 10 * MS)
    clean, clean_sink = open_scene('strapdown')
    feed(clean, 20)
    assert [a for _, _, a in sink.attitudes] == [a for _, _, a in clean_sink.attitudes]
    assert session.rejection_counts()['outlier_stamp'] == 1
    assert any('did not confirm' in text for _, text in sink.logs)


@pytest.mark.parametrize('rate', [(1e200, 0.0, 0.0), (1e308, 1e308, 1e308), (2e3, 0.0, 0.0)])
def test_absurd_rates_are_out_of_range(open_scene, rate):
    session, sink = open_scene('strapdown')
    feed(session, 5)
    assert not session.gyro(*split(BASE_NS + 5 * MS), rate)
    feed(session, 5, BASE_NS + 6 * MS)
    assert session.rejection_counts()['out_of_range'] == 1 and finite_outputs(sink)
    assert any('max_angular_rate' in text for _, text in sink.logs)


def test_set_pose_normalises_without_overflow_and_checks_the_frame(open_scene):
    session, sink = open_scene('strapdown')
    session.set_pose('world', (1e200, 1e200, 1e200, 1e200), (0.0, 0.0, 0.0))
    np.testing.assert_allclose(session.propagator.state.attitude, [0.5] * 4, rtol=1e-15)
    session.set_pose('map', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    session.set_pose('world', (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    session.set_pose('world', (math.nan, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    session.set_pose('world', (1e-320, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # subnormal: fine
    np.testing.assert_array_equal(session.propagator.state.attitude, [1.0, 0.0, 0.0, 0.0])
    counts = session.rejection_counts()
    assert (counts['wrong_frame'], counts['invalid_pose'], counts['non_finite']) == (1, 1, 1)
    assert any("expected world_frame 'world'" in text for _, text in sink.logs)
    feed(session, 3)
    assert finite_outputs(sink)


def test_malformed_messages_are_counted_per_topic_and_warned_once_per_interval(
        open_scene, clocks):
    session, sink = open_scene('strapdown')
    for _ in range(3):
        session.malformed('imu', 'truncated: 20 of 316 bytes')
    session.malformed('set_pose', 'bad encapsulation 0x0105')
    clocks.monotonic = 1.0
    report = session.report()
    values = dict(report.values)
    assert values['rejected malformed'] == '4'
    assert (values['malformed imu'], values['malformed set_pose']) == ('3', '1')
    assert report.level == LEVEL_WARN and '4 malformed in the last period' in report.message
    warnings = [text for _, text in sink.logs if 'malformed' in text]
    assert warnings == ['imu: malformed message rejected (truncated: 20 of 316 bytes) '
                        '[1 so far]']  # throttled: one per WARNING_INTERVAL


def test_no_input_and_nothing_accepted_are_not_ok(open_scene, clocks):
    session, _ = open_scene('strapdown')
    clocks.monotonic = 1.0
    assert session.report().message.startswith('no gyro input in the last period')
    for k in range(100):
        session.gyro(0, 0, OMEGA)  # unstamped
    clocks.monotonic = 2.0
    report = session.report()
    assert report.level == LEVEL_WARN and dict(report.values)['input_rate [Hz]'] == '0.0'
    assert '100 zero_stamp in the last period (parameter `use_header_stamps`)' in report.message


def test_missed_samples_raise_warn(open_scene, clocks):
    session, _ = open_scene('strapdown')
    feed(session, 100)
    # Then 100 samples with every tenth lost upstream (a stream at the same rate, with holes).
    stamps = [BASE_NS + (100 + k) * MS for k in range(111) if k % 10 != 9]
    for stamp in stamps:
        session.gyro(*split(stamp), OMEGA)
    clocks.monotonic = 1.0
    report = session.report()
    assert dict(report.values)['missed_samples'] == '11'
    assert report.message.startswith('11 samples missed upstream in the last period: 11 gaps '
                                     'of at most 1 samples'), report.message
    assert 'a deeper input queue would not help' in report.message


def test_receive_times_replace_stamps_and_reach_the_sink(open_scene, clocks):
    session, sink = open_scene('strapdown', use_header_stamps=False)
    for k in range(3):
        clocks.now_ns = BASE_NS + k * MS
        assert session.gyro(0, 0, OMEGA)  # zero stamps are fine: not used
    assert [(s, n) for s, n, _ in sink.attitudes] == [split(BASE_NS + k * MS) for k in range(3)]
    assert session.output_stamp == split(BASE_NS + 2 * MS)


def test_a_gyro_session_hands_no_energy_or_momentum(open_scene):
    """A strapdown scene simulates no body: it has no tick and no invariants to hand over."""
    session, sink = open_scene('strapdown')
    feed(session, 100)
    session.publish_diagnostics()
    assert len(sink.attitudes) == 100 and sink.invariant_samples == []
    assert not hasattr(session, 'tick')


# -- dynamics ----------------------------------------------------------------------------------

def ticks(session, clocks, count, period_ns=20 * MS, start_ns=0):
    for k in range(1, count + 1):
        clocks.now_ns = start_ns + k * period_ns
        session.tick(clocks.now_ns)


def test_huge_forces_and_torques_never_reach_an_output(open_scene, clocks):
    session, sink = open_scene('free_flyer')
    ticks(session, clocks, 5)
    session.wrench(0, 0, (1e308, 0.0, 0.0), (0.0, 0.0, 0.0))
    session.wrench(0, 0, (0.0, 0.0, 0.0), (0.0, -1e308, 1e308))
    session.wrench(0, 0, (math.inf, 0.0, 0.0), (0.0, 0.0, 0.0))
    ticks(session, clocks, 10, start_ns=clocks.now_ns)
    counts = session.rejection_counts()
    assert (counts['out_of_range'], counts['non_finite']) == (2, 1)
    assert finite_outputs(sink) and len(sink.ticks) == 15


def test_commands_count_messages_and_use_their_stamps(open_scene, clocks):
    session, _ = open_scene('free_flyer')
    ticks(session, clocks, 2)
    session.wrench(0, 50 * MS, (1.0, 0.0, 0.0), (0.0, 0.0, 0.1))
    session.wrench(0, 1_500_000_000, (1.0, 0.0, 0.0), (0.0, 0.0, 0.1))  # nanosec ≥ 1e9
    session.wrench(0, 40 * MS, (1.0, 0.0, 0.0), (0.0, 0.0, 0.1))  # older than the last
    assert session.accepted_count() == 1 and session.received_count() == 3
    counts = session.rejection_counts()
    assert (counts['invalid_stamp'], counts['stale_stamp']) == (1, 1)


def test_a_non_finite_result_restarts_the_scene_and_is_an_error(open_scene, clocks):
    # A state poisoned behind the session's back (as a faulty integrator would leave it):
    # the next tick's result is not finite, so it must not reach the sink.
    session, sink = open_scene('torque_free_box')
    ticks(session, clocks, 2)
    published = len(sink.ticks)
    session.propagator.state.attitude = np.array([math.nan, 0.0, 0.0, 1.0])
    ticks(session, clocks, 1, start_ns=clocks.now_ns)
    assert len(sink.ticks) == published
    ticks(session, clocks, 2, start_ns=clocks.now_ns)  # restarted from the initial state
    assert len(sink.ticks) == published + 2
    clocks.monotonic = 1.0
    report = session.report()
    assert finite_outputs(sink)
    counts = session.rejection_counts()  # refused by the integrator or by the result check
    assert counts['integration_failed'] + counts['non_finite_result'] == 1
    assert report.level == LEVEL_ERROR


def test_a_scene_behind_its_clock_reports_lag_and_real_time_factor(open_scene, clocks):
    session, _ = open_scene('torque_free_box')
    original = session.clock.tick

    def slow_tick(now):  # the work takes 30 ms of monotonic time per 20 ms tick
        clocks.monotonic += 0.03
        return original(now)
    session.clock.tick = slow_tick
    ticks(session, clocks, 10)
    report = session.report()
    values = dict(report.values)
    assert report.level == LEVEL_WARN and 'behind the clock' in report.message
    assert float(values['real_time_factor']) == pytest.approx(20 / 30, rel=1e-3)  # 3 digits
