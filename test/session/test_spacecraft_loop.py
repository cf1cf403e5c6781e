"""The spacecraft loop through the sessions (the node's and the controller's, in one process:
``magnetic_loop.spacecraft_loop``, bit for bit the ROS loop of ``test/ros/test_magnetic_loop.py``)
against the same laws inside the scene (the batch engine's effects):

* B-dot on the measured field detumbles the ``bdot_detumbling_commanded`` CubeSat from 10 to
  0.5 deg/s in 3 137 s, the in-scene ``bdot`` of ``bdot_detumbling`` in 3 138 s (both read
  every second); with an ideal magnetometer (noise density 1e-15 T/√Hz) the loop is the
  in-scene law: attitudes within 1e-8 rad over 600 s;
* dumping on the measured field and ``wheels/state`` takes the wheels' momentum out as the
  in-scene dumping of ``wheel_slew`` does, and without it the momentum stays.
"""

from __future__ import annotations

import math

import numpy as np
import yaml

from rigid_body_attitude.core.attitude.quaternion import attitude_error
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import ReactionWheels
from rigid_body_attitude.core.dynamics.scene import load_scene
from rigid_body_attitude.core.paths import config_folders
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.session.wheel_drive import WheelDrive

from magnetic_loop import rate_deg_s, spacecraft_loop

BDOT = {'actuator': 'magnetorquers', 'bdot_gain': 4e5, 'control_period': 1.0}
DUMPING = {'actuator': 'reaction_wheels', 'kp': 0.4, 'kd': 4.0, 'torque_limit': 0.03,
           'control_period': 0.1, 'target_rpy': (0.0, 0.0, 0.6981317)}


def in_scene_reached(scene_name: str, limit_deg_s: float, seconds: int) -> int:
    """The first whole second at which the in-scene law's rate is below ``limit_deg_s``."""
    propagator = DynamicsPropagator(load_scene(scene_name))
    for second in range(1, seconds + 1):
        propagator.advance_to(float(second))
        if math.degrees(np.linalg.norm(propagator.state.omega_body)) < limit_deg_s:
            return second
    raise AssertionError(f'not below {limit_deg_s} deg/s within {seconds} s')


def test_bdot_on_the_magnetometer_detumbles_within_a_second_of_the_in_scene_bdot():
    ticks = spacecraft_loop('bdot_detumbling_commanded', BDOT, 1.0, 3500.0,
                            stop_rate_deg_s=0.5)
    assert abs(rate_deg_s(ticks[0]) - 10.0) < 0.01
    assert ticks[-1].stamp_ns == 3137 * 10**9 and rate_deg_s(ticks[-2]) >= 0.5
    assert in_scene_reached('bdot_detumbling', 0.5, 3500) == 3138


def test_with_an_ideal_magnetometer_the_loop_is_the_in_scene_bdot(tmp_path):
    """The same field, the same instants, the same law: what is left is the magnetometer's
    1e-15 T/√Hz and the round-off of the mount and back."""
    shipped = config_folders('scenes')[0] / 'bdot_detumbling_commanded.yaml'
    data = yaml.safe_load(shipped.read_text())
    data['sensors']['magnetometer']['noise_density'] = 1e-15
    path = tmp_path / 'ideal.yaml'
    path.write_text(yaml.safe_dump(data))
    ticks = spacecraft_loop(str(path), BDOT, 1.0, 600.0)
    propagator = DynamicsPropagator(load_scene('bdot_detumbling'))
    worst = 0.0
    for tick in ticks[1:]:
        propagator.advance_to(tick.stamp_ns * 1e-9)
        worst = max(worst, float(attitude_error(np.array(tick.attitude),
                                                propagator.state.attitude)))
    print(f'\nideal magnetometer: loop against the in-scene bdot over 600 s: {worst:.3g} rad')
    assert 0.0 < worst < 1e-8
    assert rate_deg_s(ticks[-1]) < 0.75 * rate_deg_s(ticks[0])  # 10 -> 6.8 deg/s


def stored_momenta(controller_values: dict, seconds: float) -> list[np.ndarray]:
    """The wheels' stored momentum at each tick of the loop on ``wheel_slew_commanded``."""
    drive = WheelDrive(load_scene('wheel_slew_commanded'))
    momenta = []

    def record(tick_speeds):
        momenta.append(np.array(drive.stored_momentum(tick_speeds)))
    spacecraft_loop('wheel_slew_commanded', controller_values, 20.0, seconds,
                    wheel_speeds=record)
    return momenta


def test_dumping_on_the_magnetometer_takes_the_wheels_momentum_out_as_in_the_scene():
    seconds = 300.0
    dumped = stored_momenta(DUMPING | {'dumping_gain': 0.001}, seconds)
    kept = stored_momenta(DUMPING, seconds)
    propagator = DynamicsPropagator(load_scene('wheel_slew'))  # attitude_pd, dumping 0.001
    wheels = next(e for e in propagator.effects if isinstance(e, ReactionWheels))
    worst = 0.0
    for k, momentum in enumerate(dumped):
        if k:
            propagator.advance_to(k * 0.05)
        worst = max(worst, float(np.linalg.norm(momentum - wheels.stored_momentum())))
    start, end = np.linalg.norm(dumped[0]), np.linalg.norm(dumped[-1])
    print(f'\ndumping over {seconds:g} s: |h_w| {start:.6f} -> {end:.6f} N m s (in-scene '
          f'{np.linalg.norm(wheels.stored_momentum()):.6f}; without dumping '
          f'{np.linalg.norm(kept[-1]):.6f}); worst |h_loop - h_scene| {worst:.3g} N m s')
    assert end < 0.95 * start
    assert abs(np.linalg.norm(kept[-1]) - start) < 0.01 * start
    assert worst < 2e-5  # N m s, of 0.75
