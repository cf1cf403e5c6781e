"""The controller's wheel drive without ROS: the allocation, the JointState, the dipole."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_body_attitude.core.control.allocation import minimum_norm_allocation, wheel_torques
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.msgs.decoders import decode_vector3_stamped
from rigid_body_attitude.msgs.joint_state import decode_joint_state
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, controller_defaults)
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


def test_the_drive_answers_with_the_scenes_wheels_and_a_zero_dipole():
    drive = WheelDrive(load_node_scene('wheel_slew_commanded'), 'base_link')
    wheels, dipoles = [], []
    drive.answer(12, 500, (0.01, -0.02, 0.005), wheels.append, dipoles.append)
    state = decode_joint_state(wheels[0])
    assert (state.sec, state.nanosec, state.frame_id) == (12, 500, '')
    assert state.names == ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d')
    assert state.position == state.velocity == ()
    assert state.effort == drive.torques == wheel_torques(drive.allocation, (0.01, -0.02, 0.005))
    assert decode_vector3_stamped(dipoles[0]) == (12, 500, 'base_link', (0.0, 0.0, 0.0))


def test_a_scene_whose_rods_take_no_command_gets_no_dipole():
    drive = WheelDrive(load_node_scene('wheel_slew'), 'base_link')
    assert not drive.answers_dipole
    dipoles: list[bytes] = []
    drive.answer(0, 0, (0.0, 0.0, 0.0), lambda data: None, dipoles.append)
    assert dipoles == []


def test_a_scene_without_wheels_is_refused():
    with pytest.raises(SceneError, match="scene 'slew_commanded' to have reaction_wheels"):
        WheelDrive(load_node_scene('slew_commanded'), 'base_link')


def test_the_wheels_need_the_scene_parameter():
    values = controller_defaults()
    values['actuator'] = 'reaction_wheels'
    assert 'Expected parameter `scene`' in check_controller_values(values)
    values['scene'] = 'wheel_slew_commanded'
    assert check_controller_values(values) == ''
    values['actuator'] = 'thrusters'
    assert "one of 'body', 'reaction_wheels'" in check_controller_values(values)
