"""Hard case 8: bad numeric input at the core API (docs/hard-cases.md §8).

A naive core lets a NaN in (a rate, a step, an inertia entry) and carries it silently into the
state, where every later output is NaN too. Here every entry point that builds or advances a
state is fed NaN, ±Inf, wrong shapes and non-finite or singular inertia: each must raise a
``ValueError`` subclass of the package (:mod:`rigid_body_attitude.core.errors`) whose message names
the argument and shows the value, and a propagator's state must be bit-for-bit unchanged
afterwards (a rejected input never corrupts state).
"""

import copy
import math
import re

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import kinematics
from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.batch import TorqueFreeBatch
from rigid_body_attitude.core.dynamics.euler import RigidBodyModel, rk4_step
from rigid_body_attitude.core.errors import (
    AttitudeError, InertiaError, InputError, IntegratorError, SceneError)
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping

NAN = float('nan')
INF = float('inf')
Q0 = quat.normalize([0.8, -0.2, 0.3, 0.4])
OMEGA = np.array([0.3, -1.2, 2.0])


def assert_rejected(call, error, argument, value_text):
    """``call()`` raises ``error`` (a ValueError) naming ``argument`` and showing the value."""
    with pytest.raises(error) as caught:
        call()
    assert isinstance(caught.value, ValueError)
    message = str(caught.value)
    assert argument in message, message
    assert re.search(value_text, message), message


@pytest.mark.parametrize('tensor, value_text', [
    ([1.0, NAN, 1.0], r'nan'),
    ([INF, 1.0, 1.0], r'inf'),
    ([[1.0, 0.0, 0.0], [0.0, -INF, 0.0], [0.0, 0.0, 1.0]], r'-inf'),
    ([1.0, 2.0], r'\(2,\)'),
    ([[1.0, 0.0], [0.0, 1.0]], r'\(2, 2\)'),
    (np.ones((3, 3, 1)), r'\(3, 3, 1\)'),
    ('box', r"'box'"),
    ([0.0, 1.0, 1.0], r'principal moments \[0\.0'),                       # singular
    ([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 2.0]], r'principal moments'),  # singular
    ([1e-20, 1.0, 1.0], r'numerically non-singular.*1e-20'),
    ([5e-324, 1.0, 1.0], r'numerically non-singular.*5e-324'),            # subnormal moment
    ([[1.0, 1.0, 0.0], [1.0, 1.0 + 4.5e-16, 0.0], [0.0, 0.0, 2.0]], r'numerically non-singular'),
    ([1e-310, 1e-310, 1e-310], r'finite inverse'),                        # J⁻¹ overflows
    ([1.0, -2.0, 2.0], r'positive definite.*-2\.0'),
    ([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r'symmetric.*0\.1'),
])
def test_bad_inertia_rejected_everywhere(tensor, value_text):
    assert_rejected(lambda: Inertia(tensor), InertiaError, '`inertia`', value_text)
    # the batch reports a wrong shape as InputError (its own shape rules), the rest as Inertia
    assert_rejected(lambda: TorqueFreeBatch(tensor, [Q0], [OMEGA]), AttitudeError, '`inertia`',
                    value_text)
    scene = {'rate_source': 'dynamics', 'body': {'inertia': {'tensor': np.asarray(
        tensor).tolist() if not isinstance(tensor, str) else tensor}}}
    with pytest.raises(SceneError, match='body.inertia'):
        scene_from_mapping(scene)


@pytest.mark.parametrize('tensor', [[1.0, NAN, 1.0], [1.0, 2.0], [0.0, 1.0, 1.0],
                                    [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]])
def test_bad_inertia_rejected_by_the_exact_solution(tensor):
    with pytest.raises(InertiaError, match='`inertia`'):
        TorqueFreeMotion(tensor, Q0, omega_body=OMEGA)


@pytest.mark.parametrize('call, error, argument, value_text', [
    (lambda: quat.exp([NAN, 0.0, 0.0]), InputError, '`rotation_vector`', r'nan'),
    (lambda: quat.exp([1.0, 2.0]), InputError, '`rotation_vector`', r'\(2,\)'),
    (lambda: quat.log([INF, 0.0, 0.0, 0.0]), InputError, '`q`', r'inf'),
    (lambda: quat.log([1.0, 0.0, 0.0]), InputError, '`q`', r'\(3,\)'),
    (lambda: quat.normalize([0.0, 0.0, 0.0, 0.0]), InputError, '`q`', r'\[0\.0, 0\.0'),
    (lambda: quat.normalize([NAN, 1.0, 0.0, 0.0]), InputError, '`q`', r'nan'),
    (lambda: quat.to_matrix([1.0, -INF, 0.0, 0.0]), InputError, '`q`', r'-inf'),
    (lambda: quat.from_matrix(np.full((3, 3), NAN)), InputError, '`matrix`', r'nan'),
    (lambda: quat.from_matrix(np.eye(4)), InputError, '`matrix`', r'\(4, 4\)'),
    (lambda: quat.from_euler_zxz([0.1, INF, 0.0]), InputError, '`angles`', r'inf'),
    (lambda: quat.from_bryant_xyz([0.1, 0.2]), InputError, '`angles`', r'\(2,\)'),
    (lambda: quat.as_euler_zxz([NAN, 0.0, 0.0, 0.0]), InputError, '`q`', r'nan'),
    (lambda: quat.scalar_exp_step((1.0, 0.0, 0.0, 0.0), (NAN, 0.0, 0.0), 0.01), InputError,
     '`omega * dt`', r'nan'),
    (lambda: quat.scalar_exp_step((1.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0), INF), InputError,
     '`omega * dt`', r'inf'),
    (lambda: quat.scalar_exp_step((NAN, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.01), InputError,
     '`q`', r'nan'),
    (lambda: quat.scalar_exp_step((0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.01), InputError,
     '`q`', r'\(0\.0, 0\.0'),
])
def test_bad_input_to_quaternion_functions(call, error, argument, value_text):
    assert_rejected(call, error, argument, value_text)


@pytest.mark.parametrize('call, argument, value_text', [
    (lambda: kinematics.exp_map_step([NAN, 0.0, 0.0, 0.0], OMEGA, 0.01), '`attitude`', 'nan'),
    (lambda: kinematics.exp_map_step([0.0, 0.0, 0.0, 0.0], OMEGA, 0.01), '`attitude`',
     r'\[0\.0, 0\.0'),
    (lambda: kinematics.exp_map_step(Q0, [1.0, INF, 0.0], 0.01), '`omega_body`', 'inf'),
    (lambda: kinematics.exp_map_step(Q0, OMEGA, NAN), '`h`', 'nan'),
    (lambda: kinematics.exp_map_step(Q0, OMEGA, -INF), '`h`', '-inf'),
    (lambda: kinematics.exp_map_step(Q0, OMEGA, 'a'), '`h`', "'a'"),
    (lambda: kinematics.exp_map_step(Q0, [1e300, 0.0, 0.0], 1e10), 'h * omega_body',
     re.escape('1e+300')),
    (lambda: kinematics.rk4_quaternion_step(Q0, lambda t: OMEGA, 0.0, NAN), '`h`', 'nan'),
    (lambda: kinematics.rk4_quaternion_step(Q0, lambda t: [t, NAN, 0.0], 0.0, 0.1),
     '`omega_body`', 'nan'),
    (lambda: kinematics.rk4_quaternion_step([INF, 0.0, 0.0, 0.0], lambda t: OMEGA, 0.0, 0.1),
     '`attitude`', 'inf'),
])
def test_bad_input_to_kinematics(call, argument, value_text):
    assert_rejected(call, InputError, argument, value_text)


@pytest.mark.parametrize('attitude, omega, h, value_text', [
    (Q0, OMEGA, NAN, 'h=nan'),
    (Q0, OMEGA, INF, 'h=inf'),
    (np.array([NAN, 0.0, 0.0, 0.0]), OMEGA, 0.01, 'attitude=\\[nan'),
    (Q0, np.array([0.0, -INF, 0.0]), 0.01, '-inf'),
    (Q0[:3], OMEGA, 0.01, 'attitude=\\['),
    (np.stack([Q0, Q0]), OMEGA, 0.01, 'attitude=\\[\\['),
])
def test_bad_input_to_rk4_step(attitude, omega, h, value_text):
    model = RigidBodyModel(Inertia([1.0, 2.0, 3.0]))
    assert_rejected(lambda: rk4_step(model, 0.0, attitude, omega, h), InputError, '`h`',
                    value_text)


def test_rk4_step_that_overflows_raises_instead_of_returning_nan():
    # |ω| = 1e200 rad/s: ω × Jω overflows to inf in the first stage.
    model = RigidBodyModel(Inertia([1.0, 2.0, 3.0]))
    with pytest.raises(IntegratorError, match='non-finite state.*reduce the step'):
        rk4_step(model, 0.0, Q0, np.array([1e200, 1e200, 1e200]), 0.01)


def propagator_snapshot(propagator):
    """Everything a rejected input must leave untouched (deep copies)."""
    state = propagator.state
    tracker = propagator.tracker
    return (state.time, state.attitude.copy(), state.omega_body.copy(), state.position.copy(),
            tracker.initial_energy, tracker.initial_world_momentum.copy(), tracker.work,
            getattr(propagator, 'has_sample', None), copy.deepcopy(propagator.counters()))


def assert_same_snapshot(before, after):
    for old, new in zip(before, after):
        if isinstance(old, np.ndarray):
            np.testing.assert_array_equal(new, old)
        else:
            assert new == old or (isinstance(old, float) and math.isnan(old) and math.isnan(new))


def running_dynamics_propagator():
    propagator = DynamicsPropagator(load_scene('torque_free_box'))
    propagator.advance_to(0.05)
    return propagator


def running_gyro_propagator():
    propagator = GyroPropagator(load_scene('strapdown'))
    propagator.start(0.0, OMEGA)
    propagator.update(0.01, OMEGA)
    return propagator


@pytest.mark.parametrize('action, error, argument, value_text', [
    (lambda p: p.step(NAN), InputError, '`h`', 'nan'),
    (lambda p: p.step(INF), InputError, '`h`', 'inf'),
    (lambda p: p.step(0.0), InputError, '`h`', '0.0'),
    (lambda p: p.step(-0.01), InputError, '`h`', '-0.01'),
    (lambda p: p.step('0.01'), InputError, '`h`', "'0.01'"),
    (lambda p: p.advance_to(NAN), InputError, '`t_end`', 'nan'),
    (lambda p: p.advance_to(INF), InputError, '`t_end`', 'inf'),
    (lambda p: p.advance_to(1e9), InputError, 't_end', '1000000000.0'),
    (lambda p: p.set_attitude([NAN, 0.0, 0.0, 0.0]), InputError, '`attitude`', 'nan'),
    (lambda p: p.set_attitude([1.0, 0.0, 0.0]), InputError, '`attitude`', r'\(3,\)'),
    (lambda p: p.set_attitude(np.ones((2, 4))), InputError, '`attitude`', r'\(2, 4\)'),
    (lambda p: p.set_attitude([0.0, 0.0, 0.0, 0.0]), InputError, '`q`', r'\[0\.0'),
    (lambda p: p.set_attitude(Q0, [INF, 0.0, 0.0]), InputError, '`position`', 'inf'),
])
def test_dynamics_propagator_state_unchanged_after_bad_input(action, error, argument,
                                                             value_text):
    propagator = running_dynamics_propagator()
    before = propagator_snapshot(propagator)
    assert_rejected(lambda: action(propagator), error, argument, value_text)
    assert_same_snapshot(before, propagator_snapshot(propagator))
    # and it still works: the next good step advances normally
    propagator.step(0.001)
    assert propagator.state.time == pytest.approx(before[0] + 0.001, abs=1e-15)
    assert np.all(np.isfinite(propagator.state.attitude))


@pytest.mark.parametrize('action, argument, value_text', [
    (lambda p: p.update(0.02, [NAN, 0.0, 0.0]), '`omega_measured`', 'nan'),
    (lambda p: p.update(0.02, [0.0, INF, 0.0]), '`omega_measured`', 'inf'),
    (lambda p: p.update(NAN, OMEGA), '`t`', 't=nan'),
    (lambda p: p.update(INF, OMEGA), '`t`', 't=inf'),
    (lambda p: p.update(0.02, [1.0, 2.0]), '`omega_measured`', r'\(2,\)'),
    (lambda p: p.update(0.02, np.ones((2, 3))), '`omega_measured`', r'\[\[1\.0'),
    (lambda p: p.update(0.02, 'fast'), '`omega_measured`', "'fast'"),
    (lambda p: p.start(0.02, [NAN, 0.0, 0.0]), '`omega_measured`', 'nan'),
    (lambda p: p.start(-INF, OMEGA), '`t`', 't=-inf'),
    (lambda p: p.command('torque', 0.0, [1.0, 0.0, 0.0]), "'torque'", 'inputs: \\(none\\)'),
])
def test_gyro_propagator_state_unchanged_after_bad_input(action, argument, value_text):
    propagator = running_gyro_propagator()
    before = propagator_snapshot(propagator)
    assert_rejected(lambda: action(propagator), InputError, argument, value_text)
    assert_same_snapshot(before, propagator_snapshot(propagator))
    propagator.update(0.02, OMEGA)
    expected = kinematics.exp_map_step(quat.identity(), OMEGA, 0.02)
    assert quat.attitude_error(propagator.state.attitude, expected) <= 1e-15


def test_commanded_input_rejected_without_changing_the_state():
    propagator = DynamicsPropagator(load_scene('commanded_torque'))
    propagator.command('torque', 0.0, [0.0, 0.0, 0.01])
    propagator.advance_to(0.01)
    before = propagator_snapshot(propagator)
    assert_rejected(lambda: propagator.command('torque', 0.02, [NAN, 0.0, 0.0]), InputError,
                    '`torque`', 'nan')
    assert_rejected(lambda: propagator.command('torque', INF, [0.0, 0.0, 0.0]), InputError,
                    '`torque`', 't=inf')
    assert_rejected(lambda: propagator.command('torque', 0.02, [1.0, 2.0]), InputError,
                    '`torque`', r'\(2,\)')
    assert_same_snapshot(before, propagator_snapshot(propagator))


def test_batch_rejects_bad_input_and_keeps_its_state():
    batch = TorqueFreeBatch([1.0, 2.0, 3.0], [Q0, Q0], [OMEGA, -OMEGA])
    batch.rk4(0.01, 3)
    attitude, omega = batch.attitude.copy(), batch.omega_body.copy()
    for h in (NAN, INF, 0.0, -0.01):
        assert_rejected(lambda: batch.rk4(h), InputError, '`h`', re.escape(repr(h)))
    np.testing.assert_array_equal(batch.attitude, attitude)
    np.testing.assert_array_equal(batch.omega_body, omega)
    assert_rejected(lambda: TorqueFreeBatch([1.0, 2.0, 3.0], [[NAN, 0.0, 0.0, 0.0]], [OMEGA]),
                    InputError, '`attitude`', 'nan')
    assert_rejected(lambda: TorqueFreeBatch([1.0, 2.0, 3.0], [Q0], [[0.0, INF, 0.0]]),
                    InputError, '`omega_body`', 'inf')
    assert_rejected(lambda: TorqueFreeBatch([1.0, 2.0, 3.0], [Q0, Q0], [OMEGA]), InputError,
                    '`omega_body`', r'\(1, 3\)')


@pytest.mark.parametrize('kwargs, argument, value_text', [
    ({'omega_body': [NAN, 0.0, 0.0]}, '`omega_body`', 'nan'),
    ({'omega_body': [1.0, 2.0]}, '`omega_body`', r'\(2,\)'),
    ({'momentum_body': [0.0, INF, 0.0]}, '`momentum_body`', 'inf'),
    ({}, '`omega_body`', 'None'),
])
def test_exact_solution_rejects_bad_state(kwargs, argument, value_text):
    assert_rejected(lambda: TorqueFreeMotion([1.0, 2.0, 3.0], Q0, **kwargs), InputError,
                    argument, value_text)
    assert_rejected(lambda: TorqueFreeMotion([1.0, 2.0, 3.0], [NAN, 0, 0, 0], omega_body=OMEGA),
                    InputError, '`attitude`', 'nan')
    motion = TorqueFreeMotion([1.0, 2.0, 3.0], Q0, omega_body=OMEGA)
    assert_rejected(lambda: motion.state([0.0, NAN]), InputError, '`t`', 'nan')


@pytest.mark.parametrize('changes, where', [
    ({'step': NAN}, 'step'),
    ({'step': -0.001}, 'step'),
    ({'initial_state': {'omega_body': [0.0, NAN, 0.0]}}, 'omega_body'),
    ({'initial_state': {'attitude': [0.0, 0.0, 0.0, 0.0]}}, 'q'),
    ({'initial_state': {'attitude': [1.0, 0.0, 0.0]}}, 'initial_state.attitude'),
    ({'body': {'mass': INF, 'inertia': {'moments': [1.0, 2.0, 3.0]}}}, 'body.mass'),
])
def test_bad_numbers_in_a_scene(changes, where):
    scene = {'rate_source': 'dynamics', 'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
             **changes}
    with pytest.raises(SceneError, match=re.escape(where)):
        scene_from_mapping(scene)


def test_every_error_type_is_a_value_error():
    for error in (AttitudeError, InputError, InertiaError, IntegratorError, SceneError):
        assert issubclass(error, ValueError)


_LARGEST = np.finfo(np.float64).max


@pytest.mark.parametrize('block, value_text', [
    (np.diag([_LARGEST] * 3), r'at most pi\^2'),
    (np.full((3, 3), 1e308), r'at most pi\^2'),
    ([[1e308, -1e308, 0.0], [-1e308, 1e308, 0.0], [0.0, 0.0, 1.0]], r'at most pi\^2'),
    ([[1.0, 1e308, 0.0], [-1e308, 1.0, 0.0], [0.0, 0.0, 1.0]], r'symmetric'),
    (np.diag([1e-4, 1e-4, 10.0]), r'at most pi\^2.*axis z'),
    (np.diag([1.0, -1e-3, 1.0]), r'positive semi-definite'),
    (np.diag([1.0, NAN, 1.0]), r'finite'),
    ([['a', 0, 0], [0, 1, 0], [0, 0, 1]], r'matrix of numbers'),
    (np.eye(2), r'shape'),
])
def test_attitude_covariance_set_pose_refuses_without_changing_the_covariance(block,
                                                                              value_text):
    """An attitude covariance given from outside (``set_pose_with_covariance``) is refused
    whole when it is not a finite symmetric positive semi-definite 3×3 with variances at most
    π² rad², the largest floats included (no overflow, no linear-algebra error), and the
    15×15 covariance is bit-for-bit what it was."""
    from rigid_body_attitude.core.estimation.attitude_covariance import AttitudeCovariance
    covariance = AttitudeCovariance(batch_size=4)
    for _ in range(6):
        covariance.add_sample(tuple(Q0), tuple(OMEGA), 1e-3)
    before = covariance.covariance
    assert_rejected(lambda: covariance.set_pose(covariance=block), InputError, 'covariance',
                    value_text)
    assert np.array_equal(covariance.covariance, before)
