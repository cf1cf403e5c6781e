"""Campaigns with reaction wheels and magnetorquers, and the nutation statistic: defined only
for runs that turn (a spacecraft settled at rest has none)."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest
from distributed import Client, LocalCluster

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.scene import load_scene
from rigid_body_attitude.core.paths import config_folders
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.tools.campaign import (
    load_spec, main, read_runs, run_campaign, run_chunk, sample_runs, spec_from_mapping,
    SpecError)
from rigid_body_attitude.tools.campaign.statistics import BodyState, metrics, percentile_table


def shipped(name, **changes):
    path = next(folder / f'{name}.yaml' for folder in config_folders('campaigns')
                if (folder / f'{name}.yaml').is_file())
    loaded = load_spec(path)
    return dataclasses.replace(loaded, **changes)


def test_a_spinner_has_a_nutation_and_a_body_at_rest_has_none():
    inertia = np.diag([1.0, 1.0, 2.0])
    attitude = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    tilt = np.radians(10.0)
    omega = np.array([[0.0, np.sin(tilt), np.cos(tilt)],  # spinning at 1 rad/s
                      [1e-9, 2e-9, -1e-9],  # settled: rounding-level rates
                      [0.0, 0.0, 0.0]])
    state = BodyState(attitude, omega, inertia)
    values = metrics(state, state, np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]))
    nutation = values['nutation_deg']
    expected = np.degrees(np.arctan2(np.sin(tilt), 2.0 * np.cos(tilt)))  # h = J ω
    assert nutation[0] == pytest.approx(expected, rel=1e-12)
    assert np.isnan(nutation[1]) and np.isnan(nutation[2])
    table = percentile_table({'nutation_deg': nutation[:, None]}, np.ones(3, dtype=bool),
                             (50.0,))
    assert table['nutation_deg'][0, 0] == pytest.approx(expected)  # the spinner alone
    table = percentile_table({'nutation_deg': nutation[1:, None]}, np.ones(2, dtype=bool),
                             (50.0,))
    assert np.isnan(table['nutation_deg'][0, 0])


@pytest.fixture(scope='module')
def client():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=':0', silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as dask_client:
        yield dask_client


def test_slew_pointing_reports_no_nutation_once_settled_and_is_the_same_on_a_cluster(
        tmp_path, client, capsys):
    slew = shipped('slew_pointing', runs=40, chunk=20)
    local = run_campaign(slew, tmp_path / 'local', serial=True, plot=False)
    remote = run_campaign(slew, tmp_path / 'cluster', client=client, plot=False)
    a, b = read_runs(tmp_path / 'local', slew), read_runs(tmp_path / 'cluster', slew)
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=a[name].dtype.kind == 'f'), name
    nutation = a['nutation_deg']
    assert np.all(a['rate'][:, -1] < 1e-4) and np.all(np.isnan(nutation[:, -1]))
    assert np.all(np.isnan(local.statistics['nutation_deg'][:, -1]))
    # while slewing every run turns: its nutation is defined
    assert np.all(np.isfinite(nutation[:, 1]))
    np.testing.assert_array_equal(local.statistics['nutation_deg'],
                                  remote.statistics['nutation_deg'])


def test_the_cli_says_why_a_settled_campaign_has_no_nutation(tmp_path, capsys):
    spec_file = tmp_path / 'spec.yaml'
    spec_file.write_text('scene: slew\nruns: 4\nduration: 30.0\noutput_times: {every: 15.0}\n'
                         'dispersions: {attitude: {cone_deg: 5.0}}\n')
    assert main([str(spec_file), '--out', str(tmp_path / 'out'), '--serial',
                 '--no-progress']) == 0
    out = capsys.readouterr().out
    assert ('nutation_deg at 30 s (percentiles) [deg]: none: every run turns slower than '
            'statistics.nutation_min_rate') in out


def wheel_campaign(**changes):
    return shipped('wheel_slew', runs=6, chunk=3, duration=40.0,
                   output_times=(20.0, 40.0), **changes)


def test_a_wheel_campaign_records_wheel_and_dumping_statistics():
    spec = wheel_campaign()
    runs = run_chunk(spec, np.arange(6))
    assert not np.any(runs['failed'])
    assert runs['effect.reaction_wheels.axes'].shape == (6, 12)
    assert np.all(runs['wheel_speed_peak'] >= 150.0) and np.all(runs['wheel_speed_peak'] < 600)
    assert np.all(runs['wheel_time_saturated_s'] == 0.0)
    assert np.all(runs['momentum_dumped'] > 0.0)


def test_a_wheel_run_is_the_single_body_propagator_with_its_draws():
    spec = wheel_campaign()
    run = 4
    batch_run = run_chunk(spec, [run])
    drawn = sample_runs(spec, [run])
    wheels = dict(dict(spec.scene.effects)['reaction_wheels'])
    for name in ('spin_inertia', 'max_torque', 'coulomb_friction'):
        wheels[name] = drawn.effects['reaction_wheels'][name][0].tolist()
    wheels['axes'] = drawn.effects['reaction_wheels']['axes'][0].tolist()
    pd = dict(dict(spec.scene.effects)['attitude_pd'])
    pd['kp'] = float(drawn.effects['attitude_pd']['kp'][0])
    scene = spec.scene.with_overrides(effect_parameters={'reaction_wheels': wheels,
                                                         'attitude_pd': pd})
    scene = dataclasses.replace(scene, inertia=Inertia(drawn.inertia[0]),
                                initial_attitude=drawn.attitude[0],
                                initial_omega_body=drawn.omega_body[0])
    propagator = DynamicsPropagator(scene)
    for output_time in spec.output_times:
        propagator.advance_to(output_time)
    error = quaternion.attitude_error(propagator.state.attitude, batch_run['attitude'][0])
    assert float(error) < 1e-12
    assert np.max(np.abs(propagator.state.omega_body - batch_run['omega_body'][0])) < 1e-12
    assert propagator.effects[0].peak_speed == pytest.approx(
        batch_run['wheel_speed_peak'][0], rel=1e-12)
    assert propagator.effects[2].torque_impulse == pytest.approx(
        batch_run['momentum_dumped'][0], rel=1e-9)


def test_a_negative_nutation_rate_is_refused():
    with pytest.raises(SpecError, match='statistics.nutation_min_rate'):
        spec_from_mapping({'scene': 'slew', 'runs': 2, 'duration': 1.0,
                           'statistics': {'nutation_min_rate': -1.0}})


def test_the_wheel_slew_scene_settles_on_its_wheels():
    propagator = DynamicsPropagator(load_scene('wheel_slew'))
    propagator.advance_to(150.0)
    target = propagator.effects[1].target
    assert np.degrees(quaternion.attitude_error(propagator.state.attitude, target)) < 0.1
