"""The diagnostics report: levels, messages naming the governing parameter, values."""

from collections import Counter
import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.session.reports import (
    body_frame_velocity, diagnostic_report, gyro_bias_text, LEVEL_ERROR, LEVEL_OK, LEVEL_WARN,
    NOT_ALIGNED, REJECTION_KEYS, PeriodCounts, stale_command_count, state_summary)
from rigid_body_attitude.core.propagator import build_propagator
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping


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


def counts(rejections=None, new=None, received=10, accepted=10, gyro=False, **extra):
    return PeriodCounts(elapsed=1.0, received=received, accepted=accepted, accepted_total=50,
                        rejections=Counter(rejections or {}), new_rejections=Counter(new or {}),
                        gyro_scene=gyro, **extra)


def test_diagnostic_report_is_ok_for_a_fresh_torque_free_scene():
    propagator = build_propagator(load_scene('torque_free_box'))
    propagator.advance_to(1.0)
    report = diagnostic_report(propagator, counts(), '0.001', 1.0)
    values = report_values(report)
    assert (report.level, report.message) == (LEVEL_OK, 'propagating')
    assert values['scene'] == 'torque_free_box' and values['integrator'] == 'rk4'
    assert values['accepted'] == '50' and values['input_rate [Hz]'] == '10.0'
    assert [key for key, _ in report.values if key.startswith('rejected ')] == [
        f'rejected {key}' for key in REJECTION_KEYS]
    diagnostics = propagator.diagnostics()
    assert float(values['kinetic_energy [J]']) == pytest.approx(
        diagnostics.kinetic_energy, rel=1e-11)  # printed with 12 digits
    assert np.allclose([float(v) for v in values['world_angular_momentum [N m s]'].split()],
                       diagnostics.world_angular_momentum, rtol=1e-8)  # 9 digits


def test_diagnostic_report_warns_about_the_last_period_only_and_names_the_parameter():
    propagator = build_propagator(load_scene('strapdown'))
    totals = {'gap': 3, 'time_jump': 1, 'stale_stamp': 4}
    report = diagnostic_report(propagator, counts(totals, {'gap': 2, 'stale_stamp': 1},
                                                  gyro=True), 'gyro stamps', 0.0)
    assert report.level == LEVEL_WARN
    assert report.message == '2 gap in the last period (parameter `max_dt`)'
    assert report_values(report)['rejected gap'] == '3'
    quiet = diagnostic_report(propagator, counts(totals, gyro=True), 'gyro stamps', 0.0)
    assert quiet.level == LEVEL_OK


def test_inputs_with_none_accepted_warn_with_the_main_reason():
    propagator = build_propagator(load_scene('strapdown'))
    report = diagnostic_report(propagator, counts({'stale_stamp': 1949}, {'stale_stamp': 1949},
                                                  received=1949, accepted=0, gyro=True),
                               'gyro stamps', 0.0)
    assert report.level == LEVEL_WARN
    assert report.message == ('1949 inputs and none accepted in the last period, mostly '
                              'stale_stamp (parameter `use_header_stamps`)')
    assert report_values(report)['input_rate [Hz]'] == '0.0'
    assert report_values(report)['received_rate [Hz]'] == '1949.0'


def test_a_gyro_scene_without_input_warns_and_missed_samples_warn():
    propagator = build_propagator(load_scene('strapdown'))
    silent = diagnostic_report(propagator, counts(received=0, accepted=0, gyro=True), '', 0.0)
    assert silent.level == LEVEL_WARN and silent.message.startswith('no gyro input')
    missed = diagnostic_report(propagator, counts(gyro=True, missed=7, missed_total=9), '', 0.0)
    assert missed.level == LEVEL_WARN and missed.message == (
        '7 samples missed upstream in the last period')
    burst = diagnostic_report(propagator, counts(gyro=True, missed=7, missed_total=9,
                                                 missed_cause='bursts'), '', 0.0)
    assert burst.message == '7 samples missed upstream in the last period: bursts'
    assert report_values(missed)['missed_samples'] == '9'


def test_a_dynamics_scene_behind_its_clock_warns_with_lag_and_real_time_factor():
    propagator = build_propagator(load_scene('heavy_top'))
    report = diagnostic_report(propagator, counts(real_time_factor=0.8, lag=0.05,
                                                  tick_period=0.02), '0.0005', 0.0)
    assert report.level == LEVEL_WARN
    assert report.message == ('behind the clock: lag 0.050 s, real-time factor 0.80 (also '
                              '`integrator`, `publish_rate`) (parameter `step`)')
    assert report_values(report)['real_time_factor'] == '0.8'
    on_time = diagnostic_report(propagator, counts(real_time_factor=40.0, lag=0.001,
                                                   tick_period=0.02), '0.0005', 0.0)
    assert on_time.level == LEVEL_OK


@pytest.mark.parametrize('step, duration, level', [
    (0.1, 2.0, LEVEL_WARN),   # momentum drift 2.1e-6 (RK4 at ω h = 0.3)
    (0.5, 2.0, LEVEL_ERROR),  # momentum drift 1.5e-3
])
def test_diagnostic_report_raises_the_level_with_the_drift(step, duration, level):
    propagator = build_propagator(load_scene('torque_free_box').with_overrides(step=step))
    propagator.advance_to(duration)
    report = diagnostic_report(propagator, counts(), f'{step:g}', duration)
    assert report.level == level
    assert 'momentum drift' in report.message


def test_diagnostic_report_checks_no_invariant_for_gyro_scenes():
    propagator = build_propagator(load_scene('strapdown'))
    propagator.start(0.0, [0.0, 0.0, 0.0])
    propagator.update(0.01, [5.0, -3.0, 1.0])  # energy jumps with the measured rate
    report = diagnostic_report(propagator, counts(gyro=True), 'gyro stamps', 0.01)
    assert report.level == LEVEL_OK
    assert float(report_values(report)['quaternion_norm_error']) <= 1e-15
    assert quaternion.norm_error(propagator.state.attitude) <= 1e-15


def test_diagnostic_report_is_an_error_after_a_refused_integration():
    propagator = build_propagator(load_scene('commanded_torque'))
    report = diagnostic_report(propagator, counts({'integration_failed': 1, 'gap': 1},
                                                  {'integration_failed': 1, 'gap': 1}),
                               '0.001', 0.0)
    assert report.level == LEVEL_ERROR
    assert report.message == ('1 integration_failed in the last period (parameter '
                              '`integrator`); 1 gap in the last period (parameter '
                              '`time_jump_threshold`)')


ENERGY_KEYS = ('kinetic_energy [J]', 'energy_drift', 'energy_balance_residual [J]',
               'world_angular_momentum [N m s]', 'momentum_drift')


def test_a_gyro_scene_reports_rotation_bias_and_alignment_and_no_energy():
    propagator = build_propagator(load_scene('strapdown'))
    propagator.start(0.0, [0.0, 0.0, math.pi / 2])
    propagator.update(0.5, [0.0, 0.0, math.pi / 2])  # 45° about z
    values = report_values(diagnostic_report(propagator, counts(gyro=True), 'gyro stamps', 0.5))
    assert not set(ENERGY_KEYS) & set(values)
    assert float(values['rotation_from_initial [deg]']) == pytest.approx(45.0, abs=1e-9)
    assert values['gyro_bias [rad/s]'] == 'none'
    assert values['alignment'] == NOT_ALIGNED
    assert values['input_rate [Hz]'] == '10.0' and values['missed_samples'] == '0'
    summary = state_summary(propagator)
    assert summary.startswith('rotation 45.000 deg from the initial attitude, gyro bias '
                              '[rad/s] none, not aligned: ')
    assert 'energy' not in summary and ' J' not in summary


def test_a_gyro_scene_reports_the_bias_of_its_gyro_bias_effect_as_it_is_estimated():
    scene = scene_from_mapping({
        'name': 'biased', 'rate_source': 'gyro', 'integrator': 'exp_map',
        'body': {'mass': 1.0, 'inertia': {'box': {'edges': [0.1, 0.1, 0.1], 'about': 'centre'}}},
        'effects': [{'gyro_bias': {'estimate_seconds': 0.1}}]})
    propagator = build_propagator(scene)
    assert gyro_bias_text(propagator) == 'estimating (0 samples)'
    propagator.start(0.0, [0.01, -0.02, 0.03])
    for k in range(1, 30):
        propagator.update(k * 0.01, [0.01, -0.02, 0.03])
    assert gyro_bias_text(propagator) == '0.01 -0.02 0.03'
    values = report_values(diagnostic_report(propagator, counts(gyro=True), '', 0.29))
    assert values['gyro_bias [rad/s]'] == '0.01 -0.02 0.03'
    assert float(values['rotation_from_initial [deg]']) < 1e-12  # bias removed: at rest


def test_a_dynamics_scene_reports_energy_and_momentum_and_no_strapdown_values():
    propagator = build_propagator(load_scene('torque_free_box'))
    propagator.advance_to(0.5)
    values = report_values(diagnostic_report(propagator, counts(), '0.001', 0.5))
    assert set(ENERGY_KEYS) <= set(values)
    assert not {'rotation_from_initial [deg]', 'gyro_bias [rad/s]', 'alignment'} & set(values)
    assert state_summary(propagator).startswith('energy ')
