"""Tests of the stream rules (stream.py docstring): baseline, stale, gap, time jump, non-finite.

Integrated attitudes are compared with the exp-map closed form of the held rates: exact per
step, so to a few round-offs (4e−16), plus the rounding of the intervals: ``t₁ − t₀`` of stamps
near ``t`` is off by up to one spacing of ``t``, which turns into ``|ω| spacing(t)`` rad.
"""

import math

import numpy as np
import pytest

from rigid_body_attitude.core import quaternion as quat
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.scene import scene_from_mapping
from rigid_body_attitude.session.stream import ClockDriver, CommandStream, GyroStream, REASONS

MAX_DT = 0.1
JUMP = 1.0
OMEGA = [0.0, 0.0, 2.0]


def gyro_stream(constant_dt=0.0, attitude=(1.0, 0.0, 0.0, 0.0)):
    scene = scene_from_mapping({'rate_source': 'gyro', 'body': {'inertia': {'moments': [1, 1, 1]}},
                                'initial_state': {'attitude': list(attitude)}})
    return GyroStream(GyroPropagator(scene), MAX_DT, JUMP, constant_dt)


def dynamics_propagator():
    return DynamicsPropagator(scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001, 'body': {'inertia': {'moments': [1, 2, 3]}},
        'initial_state': {'omega_body': [0.0, 0.0, 1.0]},
        'effects': [{'commanded_torque': {'timeout': 1.0}}]}))


def snapshot(stream):
    state = stream.propagator.state
    return (state.time, state.attitude.copy(), state.omega_body.copy(), stream.last_stamp,
            stream.propagator.has_sample)


def assert_unchanged(stream, before):
    after = snapshot(stream)
    assert after[0] == before[0] and after[3] == before[3] and after[4] == before[4]
    np.testing.assert_array_equal(after[1], before[1])
    np.testing.assert_array_equal(after[2], before[2])


def z_rotation(angle):
    return quat.exp([0.0, 0.0, angle])


def tolerance(omega_norm, intervals, t):
    """Round-off of ``intervals`` exp-map steps with stamps near ``t`` (module docstring)."""
    return 4e-16 * intervals + omega_norm * intervals * np.spacing(t)


def test_first_sample_is_the_baseline():
    stream = gyro_stream()
    outcome = stream.add(10.0, OMEGA)
    assert outcome.accepted and not outcome.integrated and outcome.reason == ''
    state = stream.propagator.state
    assert state.time == 10.0
    np.testing.assert_array_equal(state.attitude, [1.0, 0.0, 0.0, 0.0])
    outcome = stream.add(10.05, OMEGA)
    assert outcome.accepted and outcome.integrated
    assert quat.attitude_error(state.attitude, z_rotation(2.0 * 0.05)) <= tolerance(2, 1, 10.0)


def test_stale_and_duplicate_stamps_rejected_without_change():
    stream = gyro_stream()
    stream.add(1.0, OMEGA)
    stream.add(1.05, OMEGA)
    before = snapshot(stream)
    for stamp in (1.05, 1.02, 1.05 - JUMP):    # duplicate, older, older by exactly the threshold
        outcome = stream.add(stamp, [5.0, 5.0, 5.0])
        assert not outcome.accepted and outcome.reason == 'stale_stamp' and not outcome.reset
        assert_unchanged(stream, before)
    assert stream.rejected['stale_stamp'] == 3


def test_gap_is_not_integrated_across():
    stream = gyro_stream()
    stream.add(1.0, OMEGA)
    stream.add(1.05, OMEGA)
    attitude = stream.propagator.state.attitude.copy()
    outcome = stream.add(1.05 + MAX_DT + 0.01, [0.0, 1.0, 0.0])
    assert not outcome.accepted and outcome.reason == 'gap' and not outcome.reset
    np.testing.assert_array_equal(stream.propagator.state.attitude, attitude)
    assert stream.propagator.state.time == 1.05 + MAX_DT + 0.01
    # the gap sample is the new baseline: the next interval uses its rate
    stream.add(1.05 + MAX_DT + 0.03, OMEGA)
    expected = quat.multiply(attitude, quat.exp([0.0, 0.02, 0.0]))
    assert quat.attitude_error(stream.propagator.state.attitude, expected) <= tolerance(1, 1, 1.2)


def test_interval_of_exactly_max_dt_is_integrated():
    stream = gyro_stream()
    stream.add(0.0, OMEGA)
    assert stream.add(0.0625, OMEGA).integrated          # 0.0625 < 0.1, exact in binary
    stream.max_dt = 0.0625
    assert stream.add(0.125, OMEGA).integrated           # Δt = max_dt exactly: integrated
    assert quat.attitude_error(stream.propagator.state.attitude, z_rotation(0.25)) <= 4e-16


def test_backward_time_jump_resets_to_initial_state():
    initial = quat.normalize([0.9, 0.1, 0.0, 0.2])
    stream = gyro_stream(attitude=initial)
    for k in range(10):
        stream.add(100.0 + 0.01 * k, OMEGA)
    assert quat.attitude_error(stream.propagator.state.attitude, initial) > 0.1
    outcome = stream.add(100.09 - JUMP - 0.5, [0.0, 1.0, 0.0])   # a looping bag
    assert not outcome.accepted and outcome.reason == 'time_jump' and outcome.reset
    state = stream.propagator.state
    np.testing.assert_array_equal(state.attitude, initial)
    assert state.time == 100.09 - JUMP - 0.5
    # the jump sample is the new baseline
    outcome = stream.add(100.09 - JUMP - 0.5 + 0.01, OMEGA)
    assert outcome.integrated
    expected = quat.multiply(initial, quat.exp([0.0, 0.01, 0.0]))
    assert quat.attitude_error(state.attitude, expected) <= tolerance(1, 1, 100.0)


@pytest.mark.parametrize('stamp, omega', [
    (math.nan, OMEGA), (math.inf, OMEGA), (2.0, [0.0, math.nan, 0.0]),
    (2.0, [math.inf, 0.0, 0.0]), (2.0, [1.0, 2.0])])
def test_non_finite_sample_rejected_state_unchanged(stamp, omega):
    stream = gyro_stream()
    stream.add(1.0, OMEGA)
    stream.add(1.05, OMEGA)
    before = snapshot(stream)
    outcome = stream.add(stamp, omega)
    assert not outcome.accepted and outcome.reason == 'non_finite'
    assert_unchanged(stream, before)
    # and the stream goes on as if the bad sample never came
    assert stream.add(1.1, OMEGA).integrated
    assert quat.attitude_error(stream.propagator.state.attitude,
                               z_rotation(0.2)) <= tolerance(2, 2, 1.0)


def test_non_finite_first_sample_sets_no_baseline():
    stream = gyro_stream()
    assert stream.add(math.nan, OMEGA).reason == 'non_finite'
    assert not stream.propagator.has_sample
    assert stream.add(3.0, OMEGA).accepted
    assert stream.propagator.state.time == 3.0


def test_constant_dt_ignores_stamp_differences():
    stream = gyro_stream(constant_dt=0.01)
    stream.add(5.0, OMEGA)
    for stamp in (5.013, 5.019, 5.041):       # jittery stamps, each integrated over 0.01 s
        assert stream.add(stamp, OMEGA).integrated
    assert stream.propagator.state.time == pytest.approx(5.03, abs=1e-14)
    assert quat.attitude_error(stream.propagator.state.attitude,
                               z_rotation(0.06)) <= tolerance(2, 3, 5.0)


def test_constant_dt_still_detects_gaps():
    # the gap rule comes before "integrated over constant_dt" (stream.py docstring): a
    # 5 s dropout is a new baseline, not one 10 ms step
    stream = gyro_stream(constant_dt=0.01)
    stream.add(5.0, OMEGA)
    stream.add(5.01, OMEGA)
    outcome = stream.add(10.0, [1.0, 0.0, 0.0])
    assert outcome.reason == 'gap' and not outcome.integrated
    assert quat.attitude_error(stream.propagator.state.attitude,
                               z_rotation(0.02)) <= tolerance(2, 2, 5.0)


def test_counters_add_up_to_messages():
    stream = gyro_stream()
    messages = [(0.0, OMEGA), (0.01, OMEGA), (0.01, OMEGA), (math.nan, OMEGA), (0.02, OMEGA),
                (0.5, OMEGA), (0.51, OMEGA), (-5.0, OMEGA), (-4.99, OMEGA), (-4.995, OMEGA),
                (-4.98, [math.inf, 0, 0]), (-4.97, OMEGA)]
    outcomes = [stream.add(stamp, omega) for stamp, omega in messages]
    assert stream.total == len(messages)
    assert stream.accepted + sum(stream.rejected.values()) == len(messages)
    assert stream.accepted == sum(outcome.accepted for outcome in outcomes) == 6
    assert dict(stream.rejected) == {'stale_stamp': 2, 'non_finite': 2, 'gap': 1,
                                     'time_jump': 1}
    assert set(stream.rejected) <= set(REASONS)


def test_stream_reset_starts_over():
    stream = gyro_stream()
    stream.add(1.0, OMEGA)
    stream.add(1.05, OMEGA)
    stream.reset()
    np.testing.assert_array_equal(stream.propagator.state.attitude, [1.0, 0.0, 0.0, 0.0])
    assert stream.add(0.5, OMEGA).accepted         # older stamp: a new baseline, not stale
    assert stream.propagator.state.time == 0.5


# --- commands ---------------------------------------------------------------------------------

def test_command_stream_rules():
    propagator = dynamics_propagator()
    stream = CommandStream(propagator)
    held = propagator.effects[0].command
    assert stream.add('torque', 1.0, [0.0, 0.0, 0.5]).accepted
    np.testing.assert_array_equal(held.value, [0.0, 0.0, 0.5])
    assert stream.add('torque', 1.0, [0.0, 0.0, 0.25]).accepted    # same stamp: newer value
    np.testing.assert_array_equal(held.value, [0.0, 0.0, 0.25])
    assert stream.add('torque', 0.9, [1.0, 0.0, 0.0]).reason == 'stale_stamp'
    assert stream.add('torque', 1.1, [math.nan, 0.0, 0.0]).reason == 'non_finite'
    assert stream.add('torque', math.inf, [1.0, 0.0, 0.0]).reason == 'non_finite'
    np.testing.assert_array_equal(held.value, [0.0, 0.0, 0.25])
    assert held.stamp == 1.0
    stream.reset()
    assert stream.add('torque', 0.5, [0.0, 0.0, 1.0]).accepted       # after a time jump
    assert stream.total == 6 and stream.accepted == 3
    assert dict(stream.rejected) == {'stale_stamp': 1, 'non_finite': 2}


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
    attitude = propagator.state.attitude.copy()
    outcome = clock.tick(50.1 + JUMP + 0.5)             # forward jump: skipped, not integrated
    assert outcome.reason == 'gap' and not outcome.reset
    np.testing.assert_array_equal(propagator.state.attitude, attitude)
    assert propagator.state.time == 50.1 + JUMP + 0.5
    outcome = clock.tick(10.0)                          # backward jump: the scene restarts
    assert outcome.reason == 'time_jump' and outcome.reset
    assert propagator.state.time == 10.0
    np.testing.assert_array_equal(propagator.state.attitude, [1.0, 0.0, 0.0, 0.0])
    assert clock.total == 7 and clock.accepted == 2
    assert dict(clock.rejected) == {'non_finite': 1, 'stale_stamp': 2, 'gap': 1, 'time_jump': 1}
    clock.reset()
    assert clock.tick(3.0).accepted and propagator.state.time == 3.0
