"""The nodes' interface, declared once: every topic and service, its type, direction and QoS.

:data:`NODE_INTERFACE` lists the endpoints of ``attitude_propagator`` (``propagation_node``
and ``managed_propagation_node``), :data:`CONTROLLER_INTERFACE` those of
``attitude_controller``. Each :class:`Endpoint` gives the name (relative, absolute or
private), the message or service type, the direction, the QoS profile by name
(:data:`QOS_PROFILES`; :mod:`rigid_body_attitude.ros.qos` makes the rclpy profiles of these
names), when the endpoint exists (the rate sources it belongs to and a predicate of the scene
and the parameters, :class:`Situation`, with its text for the README), what an input carries
for the session (``quantity``: its decoder follows from the type, the rate decoders of
:data:`rigid_body_attitude.msgs.decoders.RATE_DECODERS` for ``angular_rate``) and the one-line
meaning. The node creates its subscriptions, publishers and services from the entries present
for its scene, the replay reads and writes the ``replayed`` ones, and the README's topic table
and the controller's in docs/closed-loop.md are :func:`markdown_table` of these tables
(``test/session/test_interface.py`` checks both).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.yaml_files import quote
from rigid_body_attitude.msgs.joint_state import JOINT_STATE
from rigid_body_attitude.msgs.tf_message import TF_MESSAGE
from rigid_body_attitude.msgs.types import (
    ACCEL_WITH_COVARIANCE_STAMPED, CLOCK, DIAGNOSTIC_ARRAY, FLOAT64, IMU, MAGNETIC_FIELD,
    ODOMETRY, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED, QUATERNION_STAMPED, TRIGGER,
    TWIST_STAMPED, VECTOR3_STAMPED, WRENCH_STAMPED)

__all__ = ['CONTROLLER_INTERFACE', 'Endpoint', 'INPUT_DEPTH', 'Interface', 'NODE_INTERFACE',
           'OUTPUT_DEPTH', 'QOS_PROFILES', 'QosProfile', 'Situation', 'check_scene_topics',
           'markdown_table', 'qos_markdown_table']

#: Samples an input queue holds while the node cannot take them (5 s at 1 kHz).
INPUT_DEPTH = 5000
#: Samples an output writer keeps for repairs: as many as an input queue holds.
OUTPUT_DEPTH = INPUT_DEPTH

GYRO, DYNAMICS = 'gyro', 'dynamics'
_EVERY_SCENE = (GYRO, DYNAMICS)


@dataclass(frozen=True)
class QosProfile:
    """A keep-last QoS profile without rclpy: reliability (``reliable``, ``best_effort``),
    durability (``volatile``, ``transient_local``), depth, and why it is chosen."""

    name: str
    reliability: str
    durability: str
    depth: int
    why: str


#: The QoS profiles of the endpoints, by name (:mod:`rigid_body_attitude.ros.qos`: the
#: reasons at length, the rclpy profiles).
QOS_PROFILES: dict[str, QosProfile] = {profile.name: profile for profile in (
    QosProfile('sensor_input', 'best_effort', 'volatile', INPUT_DEPTH,
               'matches every sensor driver, best effort or reliable; the deep queue covers '
               'the samples that arrive while the node cannot run'),
    QosProfile('command', 'reliable', 'volatile', INPUT_DEPTH,
               'a command is sent once and must arrive'),
    QosProfile('output', 'reliable', 'volatile', OUTPUT_DEPTH,
               'reaches reliable and best-effort subscribers; the history resends what a '
               'reliable subscriber missed'),
    QosProfile('latched_output', 'reliable', 'transient_local', OUTPUT_DEPTH,
               'as `output`, and a subscriber that matches late still gets every message'),
    QosProfile('tf', 'reliable', 'volatile', 100, "as tf2_ros's broadcaster"),
    QosProfile('tf_static', 'reliable', 'transient_local', 1,
               "as tf2_ros's static broadcaster: late subscribers get it"),
    QosProfile('tf_static_listener', 'reliable', 'transient_local', 100,
               "as tf2_ros reads it (StaticListenerQoS): transforms sent before the node "
               "started arrive"),
    QosProfile('clock', 'reliable', 'volatile', 1,
               "serves rclpy's and rclcpp's time sources and reliable recorders alike"),
    QosProfile('service', 'reliable', 'volatile', 10, "rclpy's default for services"),
)}


@dataclass(frozen=True)
class Situation:
    """What decides which endpoints a node has: its scene, its parameter values, the inputs
    the scene's propagator takes, and (the replay) whether the gyro topic carries an Imu."""

    scene: Scene
    values: Mapping[str, Any]
    input_names: frozenset[str] = frozenset()
    imu_input: bool = True

    def flag(self, name: str) -> bool:
        """A boolean parameter (false when the situation has no such parameter)."""
        return bool(self.values.get(name, False))


def _always(situation: Situation) -> bool:
    return True


#: The scene keys that name an endpoint (:attr:`Endpoint.named_by`) → the name they give.
_SCENE_NAMES: dict[str, Callable[[Scene], str]] = {
    'sensors.imu.topic': lambda scene: scene.imu.topic if scene.imu is not None else '',
    'sensors.magnetometer.topic': lambda scene: (
        scene.magnetometer.topic if scene.magnetometer is not None else ''),
    'sensors.star_tracker.topic': lambda scene: (
        scene.star_tracker.topic if scene.star_tracker is not None else ''),
}


@dataclass(frozen=True)
class Endpoint:
    """One topic or service of a node.

    Attributes:
        name: relative (``imu``), absolute (``/diagnostics``) or private (``~/reset``); for an
            endpoint a scene names (:attr:`named_by`), the name when the scene gives none.
        type: the ROS message or service type (``sensor_msgs/msg/Imu``).
        direction: ``in``, ``out`` or ``service``.
        qos: the QoS profile's name (:data:`QOS_PROFILES`).
        role: how the node serves it. Inputs: ``sensor`` (a sample stream: every queued
            message taken per wake-up), ``command`` (coalesced; answers a lockstep tick),
            ``reset`` (coalesced), ``transforms``; outputs: ``output``, ``diagnostics``,
            ``clock``, ``tf``, ``tf_static``, ``simulated_sensor``; ``service``.
        quantity: what an input carries for the session (``angular_rate``, ``wrench``,
            ``rotor_torque``, ``wheel_command``, ``dipole``, ``pose``,
            ``pose_with_covariance``, ``transforms``;
            the controller's ``attitude``, ``twist``, ``target``, ``magnetic_field``,
            ``wheel_state``, ``transforms``); ``''`` for outputs.
        when: when it exists, in words (the README's).
        meaning: what it carries, one line.
        kinds: the scenes' rate sources it belongs to (``gyro``, ``dynamics``).
        condition: with :attr:`kinds`, when it exists.
        qos_overrides: its QoS may be changed at start (rclpy's ``qos_overrides``).
        replayed: the replay tool reads (an input) or writes (an output) it too.
        named_by: the scene key that names it (``sensors.imu.topic``), or ``''``.
    """

    name: str
    type: str
    direction: str
    qos: str
    role: str
    when: str
    meaning: str
    quantity: str = ''
    kinds: tuple[str, ...] = _EVERY_SCENE
    condition: Callable[[Situation], bool] = _always
    qos_overrides: bool = False
    replayed: bool = False
    named_by: str = ''

    def present(self, situation: Situation) -> bool:
        """Whether the node of ``situation`` has this endpoint."""
        return situation.scene.rate_source in self.kinds and self.condition(situation)

    def topic(self, scene: Scene) -> str:
        """The name in ``scene`` (the scene's own for an endpoint it names)."""
        return _SCENE_NAMES[self.named_by](scene) if self.named_by else self.name

    def row(self) -> str:
        """The endpoint as a row of :func:`markdown_table`."""
        name = f'`{self.name}`'
        if self.named_by:
            section, _, key = self.named_by.rpartition('.')
            name += f' (the `{section}` section\'s `{key}`)'
        kind = 'service' if self.direction == 'service' else self.direction
        return (f'| {name} | {_short(self.type)} | {kind} | {self.qos} | {self.when} | '
                f'{self.meaning} |')


def _short(type_name: str) -> str:
    """``sensor_msgs/msg/Imu`` → ``sensor_msgs/Imu`` (as the README writes types)."""
    package, _, name = type_name.split('/')
    return f'{package}/{name}'


class Interface(tuple[Endpoint, ...]):
    """A node's endpoints, in the order its documentation lists them."""

    def present(self, situation: Situation) -> Iterator[Endpoint]:
        """The endpoints of the node of ``situation``."""
        return (endpoint for endpoint in self if endpoint.present(situation))

    def inputs(self, situation: Situation, roles: tuple[str, ...] = (
            'sensor', 'command', 'reset')) -> list[Endpoint]:
        """The input topics present of the ``roles`` (the session's inputs by default)."""
        return [endpoint for endpoint in self.present(situation)
                if endpoint.direction == 'in' and endpoint.role in roles]

    def outputs(self, situation: Situation, roles: tuple[str, ...] = (
            'output', 'diagnostics')) -> list[Endpoint]:
        """The output topics present of the ``roles`` (the session's outputs by default)."""
        return [endpoint for endpoint in self.present(situation)
                if endpoint.direction == 'out' and endpoint.role in roles]

    def inputs_of_quantity(self, quantity: str) -> list[Endpoint]:
        """The inputs carrying ``quantity`` (``angular_rate``: the gyro topics), in order."""
        return [endpoint for endpoint in self
                if endpoint.direction == 'in' and endpoint.quantity == quantity]

    def endpoint(self, name: str, direction: str = 'in') -> Endpoint:
        """The endpoint ``name`` of ``direction`` (KeyError naming it when there is none)."""
        for endpoint in self:
            if endpoint.name == name and endpoint.direction == direction:
                return endpoint
        raise KeyError(f'no {direction} endpoint {name!r}')

    def names(self, direction: str, roles: tuple[str, ...] | None = None) -> tuple[str, ...]:
        """Names of the endpoints of ``direction`` (and of ``roles``), in the table's order,
        each once."""
        return tuple(dict.fromkeys(
            endpoint.name for endpoint in self if endpoint.direction == direction
            and (roles is None or endpoint.role in roles)))


def _takes(*input_names: str) -> Callable[[Situation], bool]:
    """The scene's propagator takes one of ``input_names``."""
    wanted = frozenset(input_names)
    return lambda situation: bool(situation.input_names & wanted)


def _parameter(name: str) -> Callable[[Situation], bool]:
    """The boolean parameter ``name`` is set."""
    return lambda situation: situation.flag(name)


def _estimating(update: str) -> Callable[[Situation], bool]:
    """The scene's ``estimation`` section switches ``update`` (``magnetometer`` or
    ``attitude``) on."""
    def present(situation: Situation) -> bool:
        spec = situation.scene.estimation
        if spec is None:
            return False
        return {'magnetometer': spec.magnetometer, 'attitude': spec.attitude}[update]
    return present


def _mounted_simulated_sensor(situation: Situation) -> bool:
    """A simulated sensor in a frame other than ``body_frame``."""
    return any(spec.frame_id != situation.values.get('body_frame')
               for _, spec in situation.scene.sensors.items())


def _odometry(situation: Situation) -> bool:
    """Whether the node publishes ``odom``: a dynamics scene, or a filter."""
    scene = situation.scene
    return scene.rate_source == DYNAMICS or scene.estimation is not None


def _has_wheels(situation: Situation) -> bool:
    """The scene has a reaction-wheel array."""
    return any(name == 'reaction_wheels' for name, _ in situation.scene.effects)


_PER_OUTPUT = 'every gyro sample / every tick'
_IN, _OUT = 'in', 'out'

#: The endpoints of ``attitude_propagator``.
NODE_INTERFACE = Interface((
    Endpoint('imu', IMU, _IN, 'sensor_input', 'sensor', 'gyro scenes',
             'gyro samples (`angular_velocity`; `linear_acceleration` for levelling), the '
             'sensor frame', quantity='angular_rate', kinds=(GYRO,), qos_overrides=True,
             replayed=True),
    Endpoint('angular_velocity', VECTOR3_STAMPED, _IN, 'sensor_input', 'sensor',
             'gyro scenes', 'gyro samples [rad/s], the sensor frame',
             quantity='angular_rate', kinds=(GYRO,), qos_overrides=True, replayed=True),
    Endpoint('torque', WRENCH_STAMPED, _IN, 'command', 'command',
             'scenes with `commanded_torque` / `commanded_force`',
             '`torque` [N m] (`force` [N] too with translation), body axes',
             quantity='wrench', kinds=(DYNAMICS,), condition=_takes('torque', 'force'),
             qos_overrides=True, replayed=True),
    Endpoint('rotor_torque', VECTOR3_STAMPED, _IN, 'command', 'command',
             'scenes with a commanded `rotor`', "the rotor's motor torque [N m]",
             quantity='rotor_torque', kinds=(DYNAMICS,), condition=_takes('rotor_torque'),
             qos_overrides=True, replayed=True),
    Endpoint('wheels/command', JOINT_STATE, _IN, 'command', 'command',
             'scenes with commanded `reaction_wheels`',
             'one per array: `name` every wheel, `effort` motor torques [N m] or `velocity` '
             'speeds [rad/s]', quantity='wheel_command', kinds=(DYNAMICS,),
             condition=_takes('wheel_torque', 'wheel_speed'), qos_overrides=True,
             replayed=True),
    Endpoint('dipole', VECTOR3_STAMPED, _IN, 'command', 'command',
             'scenes with commanded `magnetorquers`',
             "the torque rods' dipole [A m²], body axes", quantity='dipole',
             kinds=(DYNAMICS,), condition=_takes('dipole'), qos_overrides=True,
             replayed=True),
    Endpoint('set_pose', POSE_STAMPED, _IN, 'command', 'reset', 'always',
             're-initialises the attitude (and position), `world_frame`', quantity='pose',
             qos_overrides=True, replayed=True),
    Endpoint('set_pose_with_covariance', POSE_WITH_COVARIANCE_STAMPED, _IN, 'command',
             'reset', 'always', "as `set_pose`; a gyro scene with `covariance` also takes "
             "the attitude's covariance", quantity='pose_with_covariance',
             qos_overrides=True, replayed=True),
    Endpoint('/tf_static', TF_MESSAGE, _IN, 'tf_static_listener', 'transforms', 'gyro scenes',
             "the mount `body_frame` -> the Imu's frame", quantity='transforms',
             kinds=(GYRO,), replayed=True),
    Endpoint('imu/mag', MAGNETIC_FIELD, _IN, 'sensor_input', 'sensor',
             'scenes with `estimation: {magnetometer: true}`',
             "the magnetometer [T], its sensor frame (mount as the Imu's): heading updates",
             quantity='magnetic_field', kinds=(GYRO,), condition=_estimating('magnetometer'),
             qos_overrides=True, replayed=True),
    Endpoint('attitude_measurement', POSE_WITH_COVARIANCE_STAMPED, _IN, 'sensor_input',
             'sensor', 'scenes with `estimation: {attitude: true}`',
             'an attitude measurement (star tracker, motion capture) with its covariance, '
             '`world_frame`: an update (not a reset)', quantity='attitude_measurement',
             kinds=(GYRO,), condition=_estimating('attitude'), qos_overrides=True,
             replayed=True),
    Endpoint('orientation', QUATERNION_STAMPED, _OUT, 'output', 'output', _PER_OUTPUT,
             'the attitude, `world_frame`', qos_overrides=True, replayed=True),
    Endpoint('pose', POSE_STAMPED, _OUT, 'output', 'output', _PER_OUTPUT,
             'the attitude (and position), `world_frame`', qos_overrides=True, replayed=True),
    Endpoint('pose_with_covariance', POSE_WITH_COVARIANCE_STAMPED, _OUT, 'output', 'output',
             'gyro scenes with `covariance`, every sample',
             "the attitude's covariance about world axes (position marked unknown), "
             '`world_frame`', kinds=(GYRO,), condition=_parameter('covariance'),
             qos_overrides=True, replayed=True),
    Endpoint('imu/data', IMU, _OUT, 'output', 'output', 'gyro scenes, per `imu` sample',
             "the input (sensor frame, its rates and accelerations) with the sensor frame's "
             '`orientation` in `world_frame` (REP-145)', kinds=(GYRO,),
             condition=lambda situation: situation.imu_input, qos_overrides=True,
             replayed=True),
    Endpoint('accel/filtered', ACCEL_WITH_COVARIANCE_STAMPED, _OUT, 'output', 'output',
             'scenes with an `estimation` section, per `imu` sample',
             'the gravity-free acceleration with its covariance, `body_frame`',
             kinds=(GYRO,), condition=lambda situation: situation.imu_input and (
                 situation.scene.estimation is not None), qos_overrides=True, replayed=True),
    Endpoint('twist', TWIST_STAMPED, _OUT, 'output', 'output', 'dynamics scenes, every tick',
             'the body rate (and velocity), `body_frame`', kinds=(DYNAMICS,),
             qos_overrides=True, replayed=True),
    Endpoint('odom', ODOMETRY, _OUT, 'output', 'output',
             'dynamics scenes, every tick; scenes with an `estimation` section, every sample',
             'the pose (`world_frame`) and the twist (`body_frame`) in one message: the truth '
             '(covariances zero) or the filter\'s attitude and corrected body rate with their '
             'covariances', condition=_odometry, qos_overrides=True, replayed=True),
    Endpoint('energy', FLOAT64, _OUT, 'output', 'output', 'dynamics scenes, every tick',
             "the body's kinetic energy [J] (a gyro scene simulates no body)",
             kinds=(DYNAMICS,), qos_overrides=True, replayed=True),
    Endpoint('angular_momentum', VECTOR3_STAMPED, _OUT, 'output', 'output',
             'dynamics scenes, every tick', 'the angular momentum [N m s], `world_frame`',
             kinds=(DYNAMICS,), qos_overrides=True, replayed=True),
    Endpoint('wheels/state', JOINT_STATE, _OUT, 'output', 'output',
             'scenes with `reaction_wheels`, every tick',
             'per wheel: angle [rad], speed [rad/s] relative to the body, motor torque [N m]',
             kinds=(DYNAMICS,), condition=_has_wheels, qos_overrides=True, replayed=True),
    Endpoint('imu', IMU, _OUT, 'output', 'simulated_sensor',
             'dynamics scenes with `sensors.imu`, at its rate',
             'the simulated IMU, sensor frame, stamped with the sample time, REP-145 '
             'covariances', kinds=(DYNAMICS,),
             condition=lambda situation: situation.scene.imu is not None,
             qos_overrides=True, replayed=True, named_by='sensors.imu.topic'),
    Endpoint('imu/mag', MAGNETIC_FIELD, _OUT, 'output', 'simulated_sensor',
             'dynamics scenes with `sensors.magnetometer`, at its rate',
             'the simulated magnetometer [T], sensor frame, stamped with the sample time, its '
             'white-noise covariance', kinds=(DYNAMICS,),
             condition=lambda situation: situation.scene.magnetometer is not None,
             qos_overrides=True, replayed=True, named_by='sensors.magnetometer.topic'),
    Endpoint('star_tracker', POSE_WITH_COVARIANCE_STAMPED, _OUT, 'output', 'simulated_sensor',
             'dynamics scenes with `sensors.star_tracker`, at its rate',
             "the measured attitude of the body, `world_frame`, stamped with the sample time, "
             'its covariance about world axes (position marked unknown)', kinds=(DYNAMICS,),
             condition=lambda situation: situation.scene.star_tracker is not None,
             qos_overrides=True, replayed=True, named_by='sensors.star_tracker.topic'),
    Endpoint('/diagnostics', DIAGNOSTIC_ARRAY, _OUT, 'output', 'diagnostics',
             'once a second', 'rates, counts, rejections by reason, the status and why',
             replayed=True),
    Endpoint('/clock', CLOCK, _OUT, 'clock', 'clock', 'with `publish_clock`',
             'the sim time, every tick before the outputs', kinds=(DYNAMICS,),
             condition=_parameter('publish_clock')),
    Endpoint('/tf', TF_MESSAGE, _OUT, 'tf', 'tf', 'with `publish_tf`',
             '`world_frame` -> `body_frame`, at most `tf_rate` per second of stamps',
             condition=_parameter('publish_tf')),
    Endpoint('/tf_static', TF_MESSAGE, _OUT, 'tf_static', 'tf_static',
             'dynamics scenes with a sensor frame other than `body_frame`',
             'their mounts `body_frame` -> `frame_id`, one message, once',
             kinds=(DYNAMICS,), condition=_mounted_simulated_sensor, replayed=True),
    Endpoint('~/reset', TRIGGER, 'service', 'service', 'service', 'always',
             "back to the scene's initial state"),
))

#: The endpoints of ``attitude_controller``.
CONTROLLER_INTERFACE = Interface((
    Endpoint('odom', ODOMETRY, _IN, 'command', 'sensor', '`state_input` `odom` (default)',
             "the plant's attitude (pose, `world_frame`) and body rate (twist, angular part, "
             '`body_frame`)', quantity='odometry'),
    Endpoint('orientation', QUATERNION_STAMPED, _IN, 'command', 'sensor',
             '`state_input` `orientation_twist`', "the plant's attitude, `world_frame`",
             quantity='attitude'),
    Endpoint('twist', TWIST_STAMPED, _IN, 'command', 'sensor',
             '`state_input` `orientation_twist`',
             "the plant's body rate (the angular part), `body_frame`", quantity='twist'),
    Endpoint('target', QUATERNION_STAMPED, _IN, 'command', 'sensor', 'always',
             'a new target attitude, `world_frame`', quantity='target'),
    Endpoint('imu/mag', MAGNETIC_FIELD, _IN, 'sensor_input', 'sensor',
             '`actuator` `magnetorquers`, or a `dumping_gain`',
             'the measured field [T], its frame; tick `t` waits for the sample stamped '
             '⌊t/P⌋ P', quantity='magnetic_field'),
    Endpoint('wheels/state', JOINT_STATE, _IN, 'command', 'sensor', 'a `dumping_gain`',
             "the plant's wheel speeds (`velocity`) [rad/s], stamped like the tick",
             quantity='wheel_state'),
    Endpoint('/tf_static', TF_MESSAGE, _IN, 'tf_static_listener', 'transforms',
             'with `imu/mag`, no `magnetometer_mount_rpy`',
             "the mount `body_frame` -> the magnetometer's frame", quantity='transforms'),
    Endpoint('torque', WRENCH_STAMPED, _OUT, 'latched_output', 'output',
             '`actuator` `body` (default), every tick answered',
             'the torque, stamped like the tick it answers, `body_frame`, zero force'),
    Endpoint('wheels/command', JOINT_STATE, _OUT, 'latched_output', 'output',
             '`actuator` `reaction_wheels`, every tick answered',
             "the scene's wheels (`name`) and their motor torques [N m] (`effort`), stamped "
             'like the tick it answers'),
    Endpoint('dipole', VECTOR3_STAMPED, _OUT, 'latched_output', 'output',
             '`actuator` `magnetorquers`, or `reaction_wheels` on a scene with commanded '
             '`magnetorquers`', 'the dipole [A m²], `body_frame`: B-dot, dumping (zero without '
             '`dumping_gain`), stamped like the tick it answers'),
    Endpoint('/diagnostics', DIAGNOSTIC_ARRAY, _OUT, 'output', 'diagnostics', 'once a second',
             'pointing error, counts, rejections by reason, the status and why'),
))

_HEADER = ('| topic | type | direction | QoS | when | meaning |\n'
           '| --- | --- | --- | --- | --- | --- |')


def markdown_table(interface: Interface) -> str:
    """The interface as the Markdown table of the README (one row per endpoint)."""
    return '\n'.join([_HEADER, *(endpoint.row() for endpoint in interface)])


def qos_markdown_table() -> str:
    """The QoS profiles as the Markdown table of docs/node.md (one row per profile)."""
    rows = [f'| `{profile.name}` | {profile.reliability.replace("_", " ")} | '
            f'{profile.durability.replace("_", " ")} | keep last '
            f'{format(profile.depth, ",").replace(",", " ")} | {profile.why} |'
            for profile in QOS_PROFILES.values()]
    return '\n'.join(['| QoS | reliability | durability | history | why |',
                      '| --- | --- | --- | --- | --- |', *rows])


def check_scene_topics(scene: Scene) -> None:
    """A topic named by ``scene`` (a simulated sensor's) may be none of the node's own topics
    in a dynamics scene (relative, or the absolute ones without their slash); SceneError naming
    the key otherwise."""
    reserved = tuple(dict.fromkeys(
        endpoint.name.lstrip('/') for endpoint in NODE_INTERFACE
        if DYNAMICS in endpoint.kinds and not endpoint.named_by
        and endpoint.direction != 'service'))
    for endpoint in NODE_INTERFACE:
        if endpoint.named_by and endpoint.topic(scene) in reserved:
            raise SceneError(f"Expected {endpoint.named_by} to be none of the node's own topics "
                             f'({", ".join(reserved)}), got {quote(endpoint.topic(scene))}')
