"""reaction_wheels: momentum exchange, energy balance with friction, limits, servo, commands."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import drive_torques
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.propagator import DynamicsPropagator

TENSOR = [[10.0, 0.5, 0.2], [0.5, 12.0, 0.3], [0.2, 0.3, 8.0]]
PYRAMID = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]


def wheel_scene(step=0.01, omega=(0.05, -0.02, 0.03), integrator='rk4', effects=(),
                tensor=TENSOR, **wheels):
    parameters = {'axes': PYRAMID, 'spin_inertia': 0.02, 'max_torque': 0.05,
                  'max_speed': 600.0, 'initial_speed': [10.0, -20.0, 30.0, 5.0], **wheels}
    return scene_from_mapping({
        'rate_source': 'dynamics', 'step': step, 'integrator': integrator,
        'body': {'inertia': {'tensor': tensor}},
        'initial_state': {'omega_body': list(omega)},
        'effects': [{'reaction_wheels': parameters}, *effects]})


def run_commands(propagator, duration, period=0.5):
    """Slow torque sinusoids (periods 160 to 260 s: about 1 N m s swings of wheel momentum),
    sampled every ``period`` and held."""
    for k in range(int(duration / period)):
        t = k * period
        propagator.command('wheel_torque', t, [
            0.03 * math.sin(2 * math.pi * t / 200.0), -0.02 * math.cos(2 * math.pi * t / 160.0),
            0.03 * math.sin(2 * math.pi * t / 260.0 + 1.0), -0.01 * math.cos(t / 40.0)])
        propagator.advance_to(t + period)


def test_total_momentum_holds_to_round_off_while_the_wheels_exchange_it():
    propagator = DynamicsPropagator(wheel_scene(step=0.005))
    wheels = propagator.effects[0]
    start_momentum = propagator.world_momentum()
    start_body = propagator.state.omega_body.copy()
    run_commands(propagator, 90.0)
    start_speeds = wheels.speeds()  # a wheel momentum swing's trough
    run_commands(propagator, 500.0)
    drift = np.linalg.norm(propagator.world_momentum() - start_momentum)
    assert drift / np.linalg.norm(start_momentum) < 1e-12
    largest = max(np.abs(np.subtract(wheels.speeds(), start_speeds)) * 0.02)
    assert largest > 0.3 * np.linalg.norm(start_momentum)  # the wheels took momentum
    assert np.linalg.norm(propagator.state.omega_body - start_body) > 1e-3


def basilisk_equations(axes, spin, tensor, torque):
    """Balanced wheels as Basilisk writes them (relative speeds Ω, hub inertia with wheels):
    [J − Σ Jₛ ââᵀ] ω̇ = −ω × (J ω + Σ Jₛ Ω â) − Σ u â,  Ω̇ = u/Jₛ − â·ω̇."""
    axes = np.asarray(axes, dtype=float)
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    reduced = np.asarray(tensor) - spin * axes.T @ axes

    def rhs(t, y):
        q, omega, speeds = y[:4], y[4:7], y[7:]
        u = torque(t)
        momentum = np.asarray(tensor) @ omega + spin * axes.T @ speeds
        omega_dot = np.linalg.solve(reduced, -np.cross(omega, momentum) - axes.T @ u)
        q_dot = 0.5 * quaternion.multiply(q, np.concatenate([[0.0], omega]))
        return np.concatenate([q_dot, omega_dot, u / spin - axes @ omega_dot])
    return rhs


def test_the_wheels_match_an_independent_integration_of_basilisks_equations():
    propagator = DynamicsPropagator(wheel_scene(step=0.01))
    commands = [np.array([0.01 * math.sin(k), -0.02 * math.cos(k), 0.03, -0.01])
                for k in range(1, 21)]
    for k, command in enumerate(commands):
        propagator.command('wheel_torque', 0.5 * k, command)
        propagator.advance_to(0.5 * (k + 1))

    def torque(t):
        return commands[min(int(t / 0.5), len(commands) - 1)]
    rhs = basilisk_equations(PYRAMID, 0.02, TENSOR, torque)
    y = np.concatenate([[1.0, 0.0, 0.0, 0.0], [0.05, -0.02, 0.03], [10.0, -20.0, 30.0, 5.0]])
    for k in range(20):
        y = solve_ivp(rhs, (0.5 * k, 0.5 * (k + 1)), y, method='DOP853', rtol=1e-12,
                      atol=1e-13).y[:, -1]
    error = quaternion.attitude_error(propagator.state.attitude, y[:4] / np.linalg.norm(y[:4]))
    assert error < 1e-9
    np.testing.assert_allclose(propagator.state.omega_body, y[4:7], atol=1e-10)
    np.testing.assert_allclose(propagator.effects[0].speeds(), y[7:], atol=1e-7)


@pytest.mark.parametrize('step', [0.01, 0.005])
def test_energy_change_is_motor_work_minus_friction_loss(step):
    scene = wheel_scene(step=step, coulomb_friction=0.001, viscous_friction=1e-4)
    propagator = DynamicsPropagator(scene)
    wheels = propagator.effects[0]
    start = propagator.energy()
    run_commands(propagator, 100.0)
    change = propagator.energy() - start
    assert wheels.friction_loss > 0.1 * abs(change)  # friction did real work
    assert abs(propagator.diagnostics().energy_balance_residual) < 1e-12 * abs(change)
    # motor work and friction loss by the trapezoid on the speeds: second order in the step
    balance = change - (wheels.motor_work - wheels.friction_loss)
    assert abs(balance) < 5e-11 * (step / 0.01) ** 2 * abs(change)


def test_the_speed_limit_cuts_the_motor_and_is_counted_once_per_episode():
    scene = wheel_scene(step=0.01, max_speed=40.0, initial_speed=[39.9, 0.0, 0.0, 0.0],
                        omega=(0.0, 0.0, 0.0))
    propagator = DynamicsPropagator(scene)
    wheels = propagator.effects[0]
    propagator.command('wheel_torque', 0.0, [0.05, 0.0, 0.0, 0.0])
    propagator.advance_to(0.4)
    assert 40.0 <= wheels.speeds()[0] <= 40.0 + 0.05 * 0.01 / 0.02
    assert propagator.counters()['reaction_wheels.speed_limit'] == 1
    assert wheels.time_saturated > 0.3
    propagator.command('wheel_torque', 0.4, [-0.05, 0.0, 0.0, 0.0])  # slowing down passes
    propagator.advance_to(0.8)
    assert wheels.speeds()[0] < 39.5
    propagator.command('wheel_torque', 0.8, [0.05, 0.0, 0.0, 0.0])
    propagator.advance_to(1.6)
    assert propagator.counters()['reaction_wheels.speed_limit'] == 2


def test_the_speed_servo_reaches_the_commanded_speed_with_its_time_constant():
    scene = wheel_scene(step=0.01, speed_gain=2.0, max_torque=10.0, tensor=[1e5, 1e5, 1e5],
                        initial_speed=[0.0, 0.0, 0.0, 0.0], omega=(0.0, 0.0, 0.0), timeout=10.0)
    propagator = DynamicsPropagator(scene)
    wheels = propagator.effects[0]
    propagator.command('wheel_speed', 0.0, [100.0, -50.0, 0.0, 20.0])
    propagator.advance_to(1.5)  # three time constants
    # first-order lag held per step: (1 − gain h)^(t/h) of the error left
    left = (1.0 - 2.0 * 0.01) ** 150
    np.testing.assert_allclose(wheels.speeds(), np.array([100.0, -50.0, 0.0, 20.0]) * (1 - left),
                               rtol=2e-3, atol=2e-3)
    propagator.advance_to(6.0)
    np.testing.assert_allclose(wheels.speeds(), [100.0, -50.0, 0.0, 20.0], atol=0.01)


def test_commands_are_clipped_counted_and_time_out():
    propagator = DynamicsPropagator(wheel_scene(timeout=0.2))
    wheels = propagator.effects[0]
    propagator.command('wheel_torque', 0.0, [1.0, 0.0, 0.0, 0.0])
    assert propagator.counters()['reaction_wheels.torque_limit'] == 1
    propagator.advance_to(0.1)
    assert wheels.motor[0] == 0.05
    propagator.advance_to(0.5)
    assert wheels.motor[0] == 0.0 and propagator.counters()['reaction_wheels.stale'] == 1
    propagator.command('wheel_speed', 0.5, [1e4, 0.0, 0.0, 0.0])
    assert propagator.counters()['reaction_wheels.speed_command_limit'] == 1
    with pytest.raises(InputError, match='Expected `wheel_torque` as 4 finite numbers'):
        propagator.command('wheel_torque', 0.6, [0.0, 0.0, 0.0])
    with pytest.raises(InputError, match='to be finite'):
        propagator.command('wheel_speed', 0.6, [0.0, math.nan, 0.0, 0.0])


def test_coulomb_friction_stops_a_wheel_without_chattering():
    scene = wheel_scene(step=0.01, coulomb_friction=0.002, initial_speed=[5.0, 0.0, 0.0, 0.0],
                        omega=(0.0, 0.0, 0.0), timeout=10.0)
    propagator = DynamicsPropagator(scene)
    wheels = propagator.effects[0]
    stop = 0.02 * 5.0 / 0.002  # J Ω / f_C ignoring the body's share: 50 s
    propagator.advance_to(0.9 * stop)
    assert wheels.speeds()[0] > 0.3
    # stuck: within 1e-8 rad/s of zero (the body's motion turns the wheel's axis; the stick is
    # imposed again at every step)
    propagator.advance_to(1.2 * stop)
    assert abs(wheels.speeds()[0]) < 1e-8
    propagator.advance_to(2.0 * stop)
    assert abs(wheels.speeds()[0]) < 1e-8
    # a torque below the breakaway level leaves it stuck; above, it turns
    propagator.command('wheel_torque', 2.0 * stop, [0.0015, 0.0, 0.0, 0.0])
    propagator.advance_to(2.0 * stop + 1.0)
    assert abs(wheels.speeds()[0]) < 1e-8
    propagator.command('wheel_torque', 2.0 * stop + 1.0, [0.003, 0.0, 0.0, 0.0])
    propagator.advance_to(2.0 * stop + 2.0)
    assert wheels.speeds()[0] > 0.01


def test_drive_torques_stick_and_breakaway():
    assert drive_torques(0.0, 0.001, 0.02, 0.05, 100.0, 0.002, 0.0, 0.01) == (0.001, 0.001,
                                                                              False)
    assert drive_torques(0.0, 0.003, 0.02, 0.05, 100.0, 0.002, 0.0, 0.01) == (0.003, 0.002,
                                                                              False)
    assert drive_torques(100.0, 0.01, 0.02, 0.05, 100.0, 0.0, 0.0, 0.01) == (0.0, 0.0, True)
    assert drive_torques(-100.0, 0.01, 0.02, 0.05, 100.0, 0.0, 0.0, 0.01)[2] is False


def test_attitude_pd_drives_the_wheels_to_the_target():
    controller = {'attitude_pd': {'kp': 0.5, 'kd': 3.0, 'control_period': 0.1,
                                  'target_rpy': [0.3, -0.2, 0.5],
                                  'actuator': 'reaction_wheels'}}
    scene = wheel_scene(step=0.01, omega=(0.0, 0.0, 0.0), max_torque=0.2,
                        initial_speed=[0.0, 0.0, 0.0, 0.0], effects=[controller])
    propagator = DynamicsPropagator(scene)
    start = propagator.world_momentum()
    propagator.advance_to(120.0)
    target = propagator.effects[1].target
    assert quaternion.attitude_error(propagator.state.attitude, target) < 1e-3
    # no external torque: the wheels hold the momentum the body gave up
    assert np.linalg.norm(propagator.world_momentum() - start) < 1e-12


@pytest.mark.parametrize('parameters, key', [
    ({'axes': []}, 'axes'),
    ({'axes': [[0, 0, 0]]}, 'axes'),
    ({'axes': 'xyz'}, 'axes'),
    ({'spin_inertia': -1.0}, 'spin_inertia'),
    ({'spin_inertia': [0.1, 0.1]}, 'spin_inertia'),
    ({'max_torque': 0.0}, 'max_torque'),
    ({'max_speed': [1, 2, 3, 'x']}, 'max_speed'),
    ({'coulomb_friction': -0.1}, 'coulomb_friction'),
    ({'initial_speed': 1e300}, 'initial_speed'),
    ({'names': ['a', 'a', 'b', 'c']}, 'names'),
    ({'names': ['a', 'b']}, 'names'),
    ({'speed_gain': 200.0}, 'speed_gain'),
    ({'viscous_friction': 10.0}, 'viscous_friction'),
    ({'timeout': math.inf}, 'timeout'),
])
def test_hostile_wheel_parameters_are_one_scene_error_naming_the_key(parameters, key):
    with pytest.raises(SceneError) as raised:
        wheel_scene(**parameters)
    message = str(raised.value)
    assert f"'{key}'" in message and '\n' not in message and len(message) < 400


def test_wheels_whose_spin_inertia_the_body_cannot_hold_are_refused():
    with pytest.raises(SceneError, match="body.inertia minus the wheels' spin inertia"):
        wheel_scene(spin_inertia=9.0)
