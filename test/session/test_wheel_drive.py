"""The controller's wheel drive without ROS: the allocation, the JointState, the stored
momentum, the rods' idle dipole."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_attitude.core.control.allocation import minimum_norm_allocation, wheel_torques
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import ReactionWheels
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.msgs.joint_state import decode_joint_state
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, controller_defaults)
from rigid_body_attitude.session.magnetic_control import magnetic_control
from rigid_body_attitude.session.settings import load_node_scene
from rigid_body_attitude.session.wheel_drive import WheelDrive


def test_minimum_norm_allocation_gives_the_body_the_torque_with_the_least_wheel_torque():
    s = 1.0 / np.sqrt(3.0)
    axes = np.array([[s, s, s], [-s, s, s], [-s, -s, s], [s, -s, s]])
    allocation = minimum_norm_allocation(axes)
    rng = np.random.default_rng(3)
    for torque in rng.normal(size=(20, 3)):
        motors = np.array(wheel_torques(allocation, tuple(torque)))
        np.testing.assert_allclose(-axes.T @ motors, torque, atol=1e-14)
        # any other solution differs by a null-space vector, orthogonal to this one
        null = np.array([1.0, -1.0, 1.0, -1.0])
        assert abs(motors @ null) < 1e-14
    with pytest.raises(ValueError, match=r'shape \(N, 3\), got \(3,\)'):
        minimum_norm_allocation([1.0, 0.0, 0.0])


def test_three_orthogonal_wheels_take_minus_the_torque():
    allocation = minimum_norm_allocation(np.eye(3))
    assert wheel_torques(allocation, (0.1, -0.2, 0.3)) == pytest.approx((-0.1, 0.2, -0.3))


def test_the_drive_answers_with_the_scenes_wheels():
    drive = WheelDrive(load_node_scene('wheel_slew_commanded'))
    wheels = []
    drive.answer(12, 500, (0.01, -0.02, 0.005), wheels.append)
    state = decode_joint_state(wheels[0])
    assert (state.sec, state.nanosec, state.frame_id) == (12, 500, '')
    assert state.names == ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d')
    assert state.position == state.velocity == ()
    assert state.effort == drive.torques == wheel_torques(drive.allocation, (0.01, -0.02, 0.005))
    assert drive.answers_dipole


def test_the_rods_of_a_wheel_scene_idle_without_a_dumping_gain():
    """The plant waits for a dipole each tick: the controller's rods answer zero, needing no
    magnetometer."""
    scene = load_node_scene('wheel_slew_commanded')
    values = controller_defaults() | {'actuator': 'reaction_wheels',
                                      'scene': 'wheel_slew_commanded'}
    rods = magnetic_control(values, scene, WheelDrive(scene))
    assert rods is not None and not rods.needs_field and rods.inputs == ()
    assert rods.waiting_for(123) == '' and rods.answer(123, True) == (0.0, 0.0, 0.0)


def test_a_scene_whose_rods_take_no_command_gets_no_dipole():
    scene = load_node_scene('wheel_slew')
    drive = WheelDrive(scene)
    assert not drive.answers_dipole
    values = controller_defaults() | {'actuator': 'reaction_wheels', 'scene': 'wheel_slew'}
    assert magnetic_control(values, scene, drive) is None
    with pytest.raises(InputError, match='magnetorquers that take dipole commands for '
                                         'parameter `dumping_gain`'):
        magnetic_control(values | {'dumping_gain': 0.001}, scene, drive)


def test_the_stored_momentum_is_the_effects_of_the_same_speeds():
    scene = load_node_scene('wheel_slew_commanded')
    drive = WheelDrive(scene)
    effect = next(e for e in DynamicsPropagator(scene).effects if isinstance(e, ReactionWheels))
    assert drive.stored_momentum(effect.speeds()) == effect.stored_momentum()


def test_a_scene_without_wheels_is_refused():
    with pytest.raises(SceneError, match="scene 'slew_commanded' to have reaction_wheels"):
        WheelDrive(load_node_scene('slew_commanded'))


def test_the_wheels_need_the_scene_parameter():
    values = controller_defaults()
    values['actuator'] = 'reaction_wheels'
    assert 'Expected parameter `scene`' in check_controller_values(values)
    values['scene'] = 'wheel_slew_commanded'
    assert check_controller_values(values) == ''
    values['actuator'] = 'thrusters'
    assert "one of 'body', 'reaction_wheels', 'magnetorquers'" in check_controller_values(
        values)
