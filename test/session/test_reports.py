"""Message-boundary helpers without ROS: stamp time base, body-frame velocity, diagnostics."""

import math

import numpy as np
import pytest

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.session.reports import (
    body_frame_velocity, diagnostic_report, LEVEL_ERROR, LEVEL_OK, LEVEL_WARN, REJECTION_KEYS,
    stale_command_count, TimeBase)
from rigid_body_attitude.core.propagator import build_propagator
from rigid_body_attitude.core.scene import load_scene


def test_time_base_keeps_nanoseconds_at_realistic_epochs():
    time_base = TimeBase()
    first = time_base.seconds(1_700_000_000, 999_999_000)
    second = time_base.seconds(1_700_000_001, 999_000)
    assert first == pytest.approx(0.999999, abs=1e-15)
    # 1 ms apart: as absolute floats the difference would be off by up to 2.4e-7 s.
    assert second - first == pytest.approx(1e-3, abs=1e-15)
    assert time_base.epoch_sec == 1_700_000_000


def test_time_base_stamp_inverts_seconds():
    time_base = TimeBase()
    nanoseconds = 1_700_000_000 * 10**9 + 123_456_789
    seconds = time_base.seconds_from_nanoseconds(nanoseconds)
    assert time_base.stamp(seconds) == divmod(nanoseconds, 10**9)
    assert time_base.stamp(seconds + 2.5) == divmod(nanoseconds + 2_500_000_000, 10**9)
    assert time_base.stamp(seconds - 3.0) == divmod(nanoseconds - 3 * 10**9, 10**9)


def test_body_frame_velocity_rotates_the_world_velocity_into_body_axes():
    propagator = build_propagator(load_scene('free_flyer'))
    angle = math.pi / 2
    propagator.set_attitude([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])
    # World velocity (0.1, 0, 0) seen from a body turned 90° about z: (0, -0.1, 0).
    assert np.allclose(body_frame_velocity(propagator), (0.0, -0.1, 0.0), atol=1e-16)
    assert body_frame_velocity(build_propagator(load_scene('torque_free_box'))) == (0., 0., 0.)


def test_stale_command_count_sums_the_effects_stale_counters():
    counters = {'commanded_torque.stale': 2, 'rotor.stale': 1, 'gyro_bias.samples': 7}
    assert stale_command_count(counters) == 3


def report_values(report):
    return dict(report.values)


def test_diagnostic_report_is_ok_for_a_fresh_torque_free_scene():
    propagator = build_propagator(load_scene('torque_free_box'))
    propagator.advance_to(1.0)
    report = diagnostic_report(propagator, {}, {}, accepted=50, input_rate=0.0,
                               step_text='0.001')
    values = report_values(report)
    assert (report.level, report.message) == (LEVEL_OK, 'propagating')
    assert values['scene'] == 'torque_free_box' and values['integrator'] == 'rk4'
    assert values['accepted'] == '50'
    assert [key for key, _ in report.values if key.startswith('rejected ')] == [
        f'rejected {key}' for key in REJECTION_KEYS]
    diagnostics = propagator.diagnostics()
    assert float(values['kinetic_energy [J]']) == pytest.approx(
        diagnostics.kinetic_energy, rel=1e-11)  # printed with 12 digits
    assert np.allclose([float(v) for v in values['world_angular_momentum [N m s]'].split()],
                       diagnostics.world_angular_momentum, rtol=1e-8)  # 9 digits


def test_diagnostic_report_warns_about_gaps_and_jumps_of_the_last_period_only():
    propagator = build_propagator(load_scene('strapdown'))
    totals = {'gap': 3, 'time_jump': 1, 'stale_stamp': 4}
    report = diagnostic_report(propagator, totals, {'gap': 2, 'stale_stamp': 1}, 10, 100.0,
                               'gyro stamps')
    assert report.level == LEVEL_WARN
    assert report.message == '2 gap in the last period'
    assert report_values(report)['rejected gap'] == '3'
    quiet = diagnostic_report(propagator, totals, {}, 10, 100.0, 'gyro stamps')
    assert quiet.level == LEVEL_OK


@pytest.mark.parametrize('step, duration, level', [
    (0.1, 2.0, LEVEL_WARN),   # momentum drift 2.1e-6 (RK4 at ω h = 0.3)
    (0.5, 2.0, LEVEL_ERROR),  # momentum drift 1.5e-3
])
def test_diagnostic_report_raises_the_level_with_the_drift(step, duration, level):
    propagator = build_propagator(load_scene('torque_free_box').with_overrides(step=step))
    propagator.advance_to(duration)
    report = diagnostic_report(propagator, {}, {}, 0, 0.0, f'{step:g}')
    assert report.level == level
    assert 'momentum drift' in report.message


def test_diagnostic_report_checks_no_invariant_for_gyro_scenes():
    propagator = build_propagator(load_scene('strapdown'))
    propagator.start(0.0, [0.0, 0.0, 0.0])
    propagator.update(0.01, [5.0, -3.0, 1.0])  # energy jumps with the measured rate
    report = diagnostic_report(propagator, {}, {}, 2, 100.0, 'gyro stamps')
    assert report.level == LEVEL_OK
    assert float(report_values(report)['quaternion_norm_error']) <= 1e-15
    assert quaternion.norm_error(propagator.state.attitude) <= 1e-15


def test_diagnostic_report_is_an_error_after_a_refused_integration():
    propagator = build_propagator(load_scene('commanded_torque'))
    report = diagnostic_report(propagator, {'integration_failed': 1, 'gap': 1},
                               {'integration_failed': 1, 'gap': 1}, 0, 50.0, '0.001')
    assert report.level == LEVEL_ERROR
    assert report.message == ('1 integration_failed in the last period; '
                              '1 gap in the last period')
