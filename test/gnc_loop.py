"""The GNC loop in one process: the plant, the estimator and the controller sessions in lockstep.

What three processes run over ROS (``test/ros/test_gnc_loop.py``,
``launch/gnc_loop.launch.xml``), without the middleware: ``propagation_node`` on the
``star_tracker_pointing`` scene (``lockstep``, 100 Hz ticks) publishes each tick its simulated
gyro (``imu``) and star tracker samples; ``propagation_node`` on ``star_tracker_filter`` (the
estimator) takes them as the CDR messages the plant publishes and answers each gyro sample
with its ``odom``; ``attitude_controller`` (``actuator`` ``reaction_wheels``, ``odom``
remapped to the estimator's) answers that with the wheels' motor torques, which go back to the
plant once the tick is done. ``star_first`` chooses whether a star tracker sample reaches the
estimator before or after the gyro sample of its instant (over ROS either may come first).
CDR carries float64 exactly, so a ROS run of the same loop computes the same bits.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigid_body_attitude.msgs.joint_state import decode_joint_state
from rigid_body_attitude.session.controller import ControllerSession
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, controller_defaults)
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.settings import load_node_scene, open_session
from rigid_body_attitude.session.wheel_drive import WheelDrive

PLANT = 'star_tracker_pointing'
ESTIMATOR = 'star_tracker_filter'
TICK_RATE = 100.0
#: The estimator's gyro figures: the plant's simulated IMU's.
GYRO = {'gyroscope_noise_density': 5.0e-5, 'gyroscope_random_walk': 1.0e-6,
        'gyroscope_turn_on_bias': 5.0e-4, 'gyroscope_scale_stddev': 1.0e-4,
        'gyroscope_misalignment_stddev': 1.0e-4}
#: The controller: the PD law on the estimate, 20 degrees of yaw and 10 of roll.
TARGET_RPY = [0.17453293, 0.0, 0.34906585]
GAINS = {'kp': 0.4, 'kd': 0.8, 'torque_limit': 0.007}
CONTROLLER = {'actuator': 'reaction_wheels', 'scene': PLANT, 'target_rpy': TARGET_RPY,
              **GAINS}


@dataclass
class LoopRun:
    """What one run gives, by stamp [ns]: the truth, the estimate (attitude, its 3×3
    covariance about world axes) and the wheel commands."""

    truth: dict[int, tuple[float, ...]] = field(default_factory=dict)
    estimates: dict[int, tuple[float, ...]] = field(default_factory=dict)
    covariances: dict[int, np.ndarray] = field(default_factory=dict)
    commands: dict[int, tuple[float, ...]] = field(default_factory=dict)


class _Quiet:
    """The sink methods a side of the loop does not use."""

    use_header_stamps = True

    def __getattr__(self, name: str) -> Any:
        return lambda *args: None


@dataclass
class _PlantSink(_Quiet):
    run: LoopRun
    samples: list[tuple[str, bytes]] = field(default_factory=list)

    def dynamics(self, sec, nanosec, sample, velocity_body):
        self.run.truth[sec * 10**9 + nanosec] = sample.attitude

    def sensor_wanted(self, topic):
        return True

    def simulated_sensor(self, topic, data):
        self.samples.append((topic, data))


@dataclass
class _EstimatorSink(_Quiet):
    run: LoopRun
    controller: Any = None
    world_frame: str = 'world'
    body_frame: str = 'base_link'
    covariance: tuple[float, ...] = ()

    def attitude_covariance(self, covariance):
        self.covariance = covariance

    def odometry(self, sec, nanosec, attitude, omega_body, rate_covariance):
        stamp = sec * 10**9 + nanosec
        self.run.estimates[stamp] = attitude
        self.run.covariances[stamp] = np.reshape(self.covariance, (3, 3))
        self.controller.odometry(sec, nanosec, self.world_frame, self.body_frame, attitude,
                                 omega_body)


@dataclass
class _ControllerSink(_Quiet):
    drive: WheelDrive
    queued: list = field(default_factory=list)

    def torque(self, sec, nanosec, torque_body):
        wheels: list[bytes] = []
        self.drive.answer(sec, nanosec, torque_body, wheels.append)
        self.queued.append(decode_joint_state(wheels[0]))


def estimator_values() -> dict[str, Any]:
    """The estimator node's parameters (besides the remaps): the gyro's figures and the
    star tracker's period, which each gyro sample waits for."""
    return {'scene': ESTIMATOR, **GYRO, 'attitude_measurement_period': 0.1}


def gnc_loop(seconds: float, star_first: bool = True) -> LoopRun:
    """Run the loop for ``seconds`` of sim time (module docstring)."""
    run = LoopRun()
    plant_values = defaults() | {'scene': PLANT, 'lockstep': True, 'publish_rate': TICK_RATE,
                                 'real_time_factor': 0.0}
    plant_sink = _PlantSink(run)
    clock = [0]
    plant = open_session(load_node_scene(PLANT), plant_values, plant_sink, lambda: clock[0],
                         lambda: 0.0)
    chosen = controller_defaults() | {key: tuple(value) if isinstance(value, list) else value
                                      for key, value in CONTROLLER.items()}
    assert check_controller_values(chosen) == ''
    answers = _ControllerSink(WheelDrive(load_node_scene(PLANT)))
    controller = ControllerSession(chosen, answers, lambda: 0.0)
    estimator_sink = _EstimatorSink(run, controller)
    values = defaults() | estimator_values()
    estimator = open_session(load_node_scene(ESTIMATOR), values, estimator_sink,
                             lambda: clock[0], lambda: 0.0)
    handlers = {'imu': input_handler(estimator, 'imu'),
                'star_tracker': input_handler(estimator, 'attitude_measurement')}
    tick_ns = round(1e9 / TICK_RATE)
    for k in range(round(seconds * TICK_RATE) + 1):
        clock[0] = k * tick_ns
        plant.lockstep_tick(k * tick_ns)
        samples = sorted(plant_sink.samples, key=lambda item: (item[0] == 'imu') == star_first)
        plant_sink.samples.clear()
        for topic, data in samples:
            handlers[topic](data)
        for command in answers.queued:
            run.commands[command.sec * 10**9 + command.nanosec] = tuple(command.effort)
            plant.wheel_command(command.sec, command.nanosec, command.names, command.position,
                                command.velocity, command.effort)
        answers.queued.clear()
        assert plant.lockstep_answered(), f'tick {k} unanswered'
    return run
