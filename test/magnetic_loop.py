"""The spacecraft loop in one process (a plant session and a controller session in lockstep),
and the core's magnetometer samples from t = 0.

What ``propagation_node`` (``lockstep``) and ``attitude_controller`` run, without the
middleware between them: each tick the plant's outputs (``orientation``, ``twist``, the
simulated magnetometer's samples, ``wheels/state``) go to the controller as the CDR messages
the node would publish, its answers (``dipole``, ``wheels/command``) back to the plant once the
tick is done, as they would arrive over ROS; the magnetometer's mount goes to the controller
as the node's ``/tf_static`` does. Both sides compute with the same floats as over ROS (CDR
carries float64 exactly), so a ROS run of the same loop gives the same bits.
"""

from __future__ import annotations

from collections.abc import Callable
import math
from dataclasses import dataclass, field

from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.sensors.magnetometer import MagnetometerModel
from rigid_body_attitude.msgs.decoders import decode_magnetic_field
from rigid_body_attitude.msgs.joint_state import decode_joint_state
from rigid_body_attitude.msgs.tf_message import Transform
from rigid_body_attitude.session.controller import ControllerSession
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, controller_defaults)
from rigid_body_attitude.session.magnetic_control import magnetic_control
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.sensors import mount_transforms
from rigid_body_attitude.session.settings import load_node_scene, open_session
from rigid_body_attitude.session.wheel_drive import WheelDrive


@dataclass
class Tick:
    """The plant's outputs of one tick."""

    stamp_ns: int
    attitude: tuple[float, float, float, float]
    omega_body: tuple[float, float, float]


@dataclass
class _PlantSink:
    """The plant's outputs, handed to the controller as its subscriptions would."""

    world_frame: str
    body_frame: str
    ticks: list[Tick] = field(default_factory=list)
    controller: ControllerSession | None = None
    wheel_speeds: Callable[[tuple[float, ...]], None] | None = None
    use_header_stamps: bool = True

    def dynamics(self, sec, nanosec, sample, velocity_body):
        self.ticks.append(Tick(sec * 10**9 + nanosec, sample.attitude, sample.omega_body))
        self.controller.orientation(sec, nanosec, self.world_frame, sample.attitude)
        self.controller.twist(sec, nanosec, self.body_frame, sample.omega_body)

    def simulated_sensor(self, topic, data):
        if topic == 'imu/mag':
            sec, nanosec, frame_id, measured, _ = decode_magnetic_field(data)
            self.controller.magnetometer(sec, nanosec, frame_id, measured)

    def wheel_state(self, data):
        state = decode_joint_state(data)
        if self.wheel_speeds is not None:
            self.wheel_speeds(state.velocity)
        self.controller.wheel_state(state.sec, state.nanosec, state.names, state.velocity)

    def sensor_wanted(self, topic):
        return True

    def attitude(self, *args):
        pass

    def sensor_mount(self, *args):
        pass

    def attitude_covariance(self, *args):
        pass

    def invariants(self, *args):
        pass

    def diagnostics(self, report):
        pass

    def log(self, level, text):
        pass


@dataclass
class _ControllerSink:
    """The controller's answers, queued until the plant's tick is done."""

    drive: WheelDrive | None
    queued: list = field(default_factory=list)

    def dipole(self, sec, nanosec, dipole_body):
        self.queued.append(('dipole', (sec, nanosec, dipole_body)))

    def torque(self, sec, nanosec, torque_body):
        wheels = []
        self.drive.answer(sec, nanosec, torque_body, wheels.append)
        self.queued.append(('wheels', decode_joint_state(wheels[0])))

    def diagnostics(self, report):
        pass

    def log(self, level, text):
        pass


def spacecraft_loop(scene_name: str, controller_values: dict, publish_rate: float,
                    seconds: float, stop_rate_deg_s: float = 0.0,
                    wheel_speeds: Callable[[tuple[float, ...]], None] | None = None
                    ) -> list[Tick]:
    """Run the loop for ``seconds`` of sim time (ticks at ``publish_rate``) or until the body
    rate falls below ``stop_rate_deg_s``; the plant's ticks (``wheel_speeds``: called with
    each tick's ``wheels/state`` speeds)."""
    scene = load_node_scene(scene_name)
    values = defaults() | {'scene': scene_name, 'lockstep': True,
                           'publish_rate': publish_rate, 'real_time_factor': 0.0}
    plant_sink = _PlantSink(values['world_frame'], values['body_frame'],
                            wheel_speeds=wheel_speeds)
    clock = [0]
    plant = open_session(scene, values, plant_sink, lambda: clock[0], lambda: 0.0)
    chosen = controller_defaults() | {'scene': scene_name} | {
        key: tuple(value) if isinstance(value, list) else value
        for key, value in controller_values.items()}
    assert check_controller_values(chosen) == ''
    drive = WheelDrive(scene) if chosen['actuator'] == 'reaction_wheels' else None
    answers = _ControllerSink(drive)
    controller = ControllerSession(chosen, answers, lambda: 0.0,
                                   magnetic_control(chosen, scene, drive))
    plant_sink.controller = controller
    controller.transforms([Transform(0, 0, parent, child, (0.0, 0.0, 0.0), q)
                           for parent, child, q in mount_transforms(scene, values['body_frame'])])
    tick_ns = round(1e9 / publish_rate)
    for k in range(round(seconds * publish_rate) + 1):
        clock[0] = k * tick_ns
        plant.lockstep_tick(k * tick_ns)
        for kind, answer in answers.queued:
            if kind == 'dipole':
                plant.dipole(*answer)
            else:
                plant.wheel_command(answer.sec, answer.nanosec, answer.names, answer.position,
                                    answer.velocity, answer.effort)
        answers.queued.clear()
        assert plant.lockstep_answered(), f'tick {k} unanswered'
        if stop_rate_deg_s and rate_deg_s(plant_sink.ticks[-1]) < stop_rate_deg_s:
            break
    return plant_sink.ticks


def rate_deg_s(tick: Tick) -> float:
    """The body rate's magnitude [deg/s]."""
    return math.degrees(math.sqrt(sum(value * value for value in tick.omega_body)))


def core_field_samples(scene_name: str, first_ns: int, tick_ns: int, ticks: int,
                       stamps: list[int]) -> list[tuple[float, float, float]]:
    """The core from scene time 0: the scene's propagator stopped at the ticks ``k tick_ns``
    and the sample instants ``stamps`` (clock times, scene time measured from ``first_ns``,
    the first tick's), and the scene's magnetometer model sampled at ``stamps``."""
    scene = load_node_scene(scene_name)
    propagator = DynamicsPropagator(scene)
    model = MagnetometerModel(scene.sensors.magnetometer, scene.magnetic_field)
    wanted = {stamp - first_ns for stamp in stamps}
    samples = []
    for offset_ns in sorted({*(k * tick_ns for k in range(ticks)), *wanted}):
        t = offset_ns * 1e-9
        propagator.advance_to(t)
        if offset_ns in wanted:
            samples.append(model.sample(t, propagator.state.attitude_tuple()))
    return samples
