"""Tests of the stream rules (stream.py docstring): baseline, stale, jumps confirmed or not,
outliers, missed samples, bounds, non-finite; commands; clock ticks.

Times are integer nanoseconds. Integrated attitudes are compared with the exp-map closed form
of the held rates: exact per step, so to a few round-offs (4e−16 per step); the stamps are
exact integers, so the steps carry no rounding of their own.
"""

import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.session.stream import (
    ClockDriver, COMMAND_LIMIT, CommandStream, GyroStream, JUMP_CONFIRMATIONS, PERIOD_BATCH)

MAX_DT = 0.1
JUMP = 1.0
OMEGA = [0.0, 0.0, 2.0]
MS = 1_000_000
BASE = 1_700_000_000 * 10**9 + 123_456_789


def gyro_stream(constant_dt=0.0, max_rate=math.inf):
    scene = scene_from_mapping({'rate_source': 'gyro',
                                'body': {'inertia': {'moments': [1, 1, 1]}}})
    return GyroStream(GyroPropagator(scene), MAX_DT, JUMP, constant_dt, max_rate)


def dynamics_propagator():
    return DynamicsPropagator(scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001, 'body': {'inertia': {'moments': [1, 2, 3]}},
        'initial_state': {'omega_body': [0.0, 0.0, 1.0]},
        'effects': [{'commanded_torque': {'timeout': 1.0}}]}))


def z_rotation(angle):
    return quat.exp([0.0, 0.0, angle])


def attitude(stream):
    return stream.propagator.state.attitude


def feed(stream, offsets_ms, rate=OMEGA):
    return [stream.add(BASE + round(offset * MS), rate) for offset in offsets_ms]


def test_first_sample_is_the_baseline_then_steps_integrate():
    stream = gyro_stream()
    first, second = feed(stream, [0, 10])
    assert first.accepted and not first.integrated and second.integrated
    assert quat.attitude_error(attitude(stream), z_rotation(0.02)) <= 4e-16


def test_stale_and_duplicate_stamps_rejected_without_change():
    stream = gyro_stream()
    feed(stream, [0, 10])
    before = attitude(stream).copy()
    outcomes = feed(stream, [10, 5, 10 - 999])  # duplicate, out of order, back < threshold
    assert [o.reason for o in outcomes] == ['stale_stamp'] * 3
    np.testing.assert_array_equal(attitude(stream), before)


@pytest.mark.parametrize('outlier_ms', [500.0, 10 + 2**31 * 1e3, 10 - 5000.0])
def test_a_lone_outlier_stamp_is_rejected_and_the_stream_goes_on(outlier_ms):
    """Forward (a gap), far in the future (sec = 2³¹) and far back (a loop) alike."""
    stream = gyro_stream()
    feed(stream, [0, 10])
    assert feed(stream, [outlier_ms])[0].pending
    outcomes = feed(stream, [20, 30])
    assert all(o.integrated and not o.reason for o in outcomes)
    assert dict(stream.rejected) == {'outlier_stamp': 1} and stream.outliers == 1
    assert quat.attitude_error(attitude(stream), z_rotation(0.06)) <= 3 * 4e-16
    assert stream.total == 5


def test_a_forward_gap_is_taken_when_the_next_samples_confirm_it():
    stream = gyro_stream()
    feed(stream, [0, 10])  # 0.02 rad
    outcomes = feed(stream, [510, 520, 530])
    assert [o.pending for o in outcomes] == [True] * JUMP_CONFIRMATIONS + [False]
    assert outcomes[-1].integrated and outcomes[-1].reason == 'gap' and not outcomes[-1].reset
    # Held across the gap, then two 10 ms steps: 0.02 + 0.04 rad.
    assert quat.attitude_error(attitude(stream), z_rotation(0.06)) <= 3 * 4e-16
    assert dict(stream.rejected) == {'gap': 1} and stream.accepted == 4


def test_a_jump_back_is_a_reset_when_confirmed():
    stream = gyro_stream()
    feed(stream, [0, 10, 20])
    outcomes = feed(stream, [-5000, -4990, -4980])
    assert outcomes[-1].reset and outcomes[-1].reason == 'time_jump'
    # Reset to the initial attitude at −5000 ms, then two steps.
    assert quat.attitude_error(attitude(stream), z_rotation(0.04)) <= 2 * 4e-16
    assert dict(stream.rejected) == {'time_jump': 1}


def test_a_new_outlier_while_pending_replaces_the_candidate():
    stream = gyro_stream()
    feed(stream, [0, 10])
    assert feed(stream, [500])[0].pending
    assert feed(stream, [900])[0].pending  # neither line: 500 was an outlier, 900 waits
    feed(stream, [20])
    assert stream.rejected['outlier_stamp'] == 2 and not stream.pending


@pytest.mark.parametrize('rate', [[math.nan, 0.0, 0.0], [0.0, math.inf, 0.0], [1.0, 2.0]])
def test_non_finite_or_short_rates_rejected_state_unchanged(rate):
    stream = gyro_stream()
    feed(stream, [0])
    assert feed(stream, [10], rate)[0].reason == 'non_finite'
    np.testing.assert_array_equal(attitude(stream), [1.0, 0.0, 0.0, 0.0])


def test_rates_above_the_bound_are_out_of_range_even_if_squaring_overflows():
    stream = gyro_stream(max_rate=1000.0)
    feed(stream, [0])
    assert feed(stream, [10], [1e200, 0.0, 0.0])[0].reason == 'out_of_range'
    assert feed(stream, [10], [600.0, 600.0, 600.0])[0].reason == 'out_of_range'  # |ω| 1039
    assert feed(stream, [10], [0.0, 0.0, 999.0])[0].integrated


def test_missed_samples_are_counted_from_the_learnt_period():
    stream = gyro_stream()
    offsets = [k * 1.0 for k in range(PERIOD_BATCH + 1)]  # 1 kHz: one batch learns the period
    feed(stream, offsets)
    assert stream.missed_samples == 0 and stream.period.period_ns == MS
    last = offsets[-1]
    feed(stream, [last + 3.0])  # 2 lost
    feed(stream, [last + 4.0, last + 9.0])  # 4 lost
    stream.settle()  # a partial batch of gaps alone: its median is not the period, it waits
    assert stream.missed_samples == 0
    feed(stream, [last + 10.0 + k for k in range(5)])
    stream.settle()  # now its median is the period
    assert stream.missed_samples == 6
    last += 14.0
    feed(stream, [last + 80.0, last + 81.0, last + 82.0])  # a step of 80 periods
    stream.settle()
    assert stream.missed_samples == 6 + 79
    feed(stream, [last + 300.0, last + 301.0, last + 302.0])  # a confirmed gap (> max_dt)
    assert stream.missed_samples == 6 + 79 + 217


def test_receive_times_count_no_missed_samples():
    stream = gyro_stream()
    stream.count_missed = False
    feed(stream, [k * 1.0 for k in range(40)] + [50.0])
    assert stream.missed_samples == 0


def test_constant_dt_ignores_stamp_differences():
    stream = gyro_stream(constant_dt=0.005)
    feed(stream, [0, 7, 8, 30])
    assert quat.attitude_error(attitude(stream), z_rotation(0.03)) <= 3 * 4e-16


def test_reset_starts_over_and_forgets_a_pending_jump():
    stream = gyro_stream()
    feed(stream, [0, 10, 500])
    stream.reset()
    assert not stream.pending
    np.testing.assert_array_equal(attitude(stream), [1.0, 0.0, 0.0, 0.0])
    assert feed(stream, [-20000])[0].accepted  # any stamp: a new baseline


# --- commands ---------------------------------------------------------------------------------

def test_command_stream_rules():
    propagator = dynamics_propagator()
    stream = CommandStream(propagator)
    held = propagator.effects[0].command
    assert stream.add('torque', 1000, 1.0, [0.0, 0.0, 0.5]).accepted
    np.testing.assert_array_equal(held.value, [0.0, 0.0, 0.5])
    assert stream.add('torque', 1000, 1.0, [0.0, 0.0, 0.25]).accepted  # same stamp: newer
    np.testing.assert_array_equal(held.value, [0.0, 0.0, 0.25])
    assert stream.add('torque', 900, 0.9, [1.0, 0.0, 0.0]).reason == 'stale_stamp'
    assert stream.add('torque', 1100, 1.1, [math.nan, 0.0, 0.0]).reason == 'non_finite'
    assert stream.add('torque', 1100, 1.1, [2 * COMMAND_LIMIT, 0, 0]).reason == 'out_of_range'
    assert stream.add('torque', 1100, 1.1, [1e308, 1e308, 0]).reason == 'out_of_range'
    np.testing.assert_array_equal(held.value, [0.0, 0.0, 0.25])
    stream.reset()
    assert stream.add('torque', 500, 0.5, [0.0, 0.0, 1.0]).accepted  # after a time jump
    assert stream.total == 7 and stream.accepted == 3
    assert dict(stream.rejected) == {'stale_stamp': 1, 'non_finite': 1, 'out_of_range': 2}


# --- clock ticks --------------------------------------------------------------------------------

def test_clock_driver_rules():
    propagator = dynamics_propagator()
    clock = ClockDriver(propagator, time_jump_threshold=JUMP)
    assert clock.tick(math.nan).reason == 'non_finite'
    assert not clock.started
    outcome = clock.tick(50.0)                          # first tick: the scene starts here
    assert outcome.accepted and not outcome.integrated and propagator.state.time == 50.0
    assert clock.tick(50.1).integrated
    # ω = e_z about a principal axis: exact attitude exp(0.1 e_z), RK4 error ~(0.001)⁴
    assert quat.attitude_error(propagator.state.attitude, z_rotation(0.1)) <= 1e-13
    assert clock.tick(50.1).reason == 'stale_stamp'
    assert clock.tick(50.05).reason == 'stale_stamp'
    held = propagator.state.attitude.copy()
    outcome = clock.tick(50.1 + JUMP + 0.5)             # forward jump: skipped, not integrated
    assert outcome.reason == 'gap' and not outcome.reset and outcome.moved
    np.testing.assert_array_equal(propagator.state.attitude, held)
    assert propagator.state.time == 50.1 + JUMP + 0.5
    outcome = clock.tick(10.0)                          # backward jump: the scene restarts
    assert outcome.reason == 'time_jump' and outcome.reset
    assert propagator.state.time == 10.0
    np.testing.assert_array_equal(propagator.state.attitude, [1.0, 0.0, 0.0, 0.0])
    assert clock.total == 7 and clock.accepted == 2
    assert dict(clock.rejected) == {'non_finite': 1, 'stale_stamp': 2, 'gap': 1, 'time_jump': 1}
    clock.reset()
    assert clock.tick(3.0).accepted and propagator.state.time == 3.0


# --- resume (a managed node reactivated) ------------------------------------------------------

def test_gyro_stream_resume_keeps_the_attitude_and_integrates_nothing_across_the_pause():
    stream = gyro_stream()
    for k in range(11):                                  # 0.1 s at 2 rad/s about z
        stream.add(BASE + k * 10 * MS, OMEGA)
    held = attitude(stream).copy()
    assert quat.attitude_error(held, z_rotation(0.2)) <= 1e-14
    stream.resume()
    outcome = stream.add(BASE + 30 * 10 * MS, OMEGA)     # 0.2 s later (< max_dt: not a gap)
    assert outcome.accepted and not outcome.integrated and not outcome.reason
    np.testing.assert_array_equal(attitude(stream), held)
    assert stream.propagator.state.time == pytest.approx(0.1, abs=1e-15)  # no pause in it
    assert stream.add(BASE + 31 * 10 * MS, OMEGA).integrated
    assert quat.attitude_error(attitude(stream), z_rotation(0.22)) <= 1e-14
    assert stream.propagator.state.time == pytest.approx(0.11, abs=1e-15)
    assert not stream.rejected


def test_clock_driver_resume_skips_the_pause_without_counting_it():
    propagator = dynamics_propagator()
    clock = ClockDriver(propagator, time_jump_threshold=JUMP)
    clock.tick(50.0)
    clock.tick(50.1)
    held = propagator.state.attitude.copy()
    clock.resume()
    outcome = clock.tick(50.6)                           # 0.5 s later (< JUMP: not a gap)
    assert outcome.accepted and not outcome.integrated and not outcome.reason
    np.testing.assert_array_equal(propagator.state.attitude, held)
    assert propagator.state.time == 50.6
    assert clock.tick(50.7).integrated
    assert quat.attitude_error(propagator.state.attitude, z_rotation(0.2)) <= 1e-13
    assert not clock.rejected
