"""The ``attitude_propagator`` node (executable ``propagation_node``): an rclpy adapter.

Every subscription is raw: each callback decodes the CDR bytes with the project's checked
decoders (:mod:`rigid_body_attitude.msgs`) and hands the plain values to the scene's
session (:mod:`rigid_body_attitude.session`), which applies the time rules, advances the
propagator, counts, and gives what is to be published to :class:`~.outputs.RosOutputs`. A
message that cannot be decoded is handed to the session as malformed: rejected, counted per
topic, warned about. Nothing here integrates or decides about time; the replay tool feeds the
same session, so a replayed bag gives the same numbers.

* Gyro scenes advance on each ``imu`` (sensor_msgs/Imu) or ``angular_velocity``
  (geometry_msgs/Vector3Stamped) message and publish ``orientation``, ``pose``,
  ``pose_with_covariance`` (parameter ``covariance``) and (for Imu input) ``imu/data`` per
  message. Spun in-process by any executor the node works as usual,
  one message per callback; :func:`~.serve.main` serves the gyro subscriptions and timers with
  a :class:`~.gyro_loop.GyroLoop` (every queued message per wake-up).
* Dynamics scenes advance on a timer of the node clock (``use_sim_time`` works) at
  ``publish_rate``, served by the same gyro loop (timers only); commands arrive on
  ``torque`` (WrenchStamped) and ``rotor_torque`` (Vector3Stamped) when the scene takes them.
  ``~/reset`` restores the scene's initial state. A scene with ``sensors`` also publishes its
  simulated IMU (``sensor_msgs/msg/Imu``, :mod:`rigid_body_attitude.session.sensors`) and the
  sensor's mount on ``/tf_static``. With ``publish_clock`` or ``lockstep`` the scene is its own
  clock instead: a :class:`~.step_loop.StepLoop` makes the ticks on sim time (``/clock``,
  ``real_time_factor``, lockstep; docs/closed-loop.md).
* Commands (``set_pose``, ``set_pose_with_covariance``, ``torque``, ``rotor_torque``) are
  coalesced: only the newest of each topic matters, so each callback takes every message queued
  behind its own and hands the newest to the session once (the others counted ``superseded``). Log
  lines go through a queue with a thread of its own (:mod:`~.log_queue`), never written while the
  state lock is held.
* Gyro scenes read the sensor's mount from ``/tf_static`` when the samples' frame is not
  ``body_frame`` and ``mount_rpy`` is not set (:mod:`~.tf_lookup`); with ``publish_tf`` the
  attitude also goes to ``/tf``.

Parameters are declared from :data:`rigid_body_attitude.session.parameters.PARAMETERS`.
"""

from __future__ import annotations

import array
import threading
import time
from collections.abc import Callable
from typing import Any

from geometry_msgs.msg import (
    PoseStamped, PoseWithCovarianceStamped, Vector3Stamped, WrenchStamped)
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import (
    InvalidParameterTypeException, ParameterException, ParameterUninitializedException)
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter
from rclpy.qos_overriding_options import QoSOverridingOptions
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rosgraph_msgs.msg import Clock as ClockMessage
from sensor_msgs.msg import Imu
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.decoding import DECODERS, input_handler, MALFORMED
from rigid_body_attitude.ros.gyro_loop import DedicatedGroup, GyroLoop
from rigid_body_attitude.ros.outputs import RosOutputs
from rigid_body_attitude.ros.qos import (
    CLOCK_QOS, COMMAND_QOS, GYRO_QOS, TF_STATIC_LISTENER_QOS)
from rigid_body_attitude.ros.step_loop import step_loop
from rigid_body_attitude.ros.tf_lookup import MountGate
from rigid_body_attitude.ros.rclpy_internals import clock_nanoseconds, raw_taker
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.parameters import Parameter, PARAMETERS, check_values
from rigid_body_attitude.session.settings import (
    DIAGNOSTICS_PERIOD, input_topics, load_node_scene, NODE_NAME, open_session, AnySession,
    timer_period_ns)
from rigid_body_attitude.session.sim_clock import sim_clock_for, sim_clock_problem

__all__ = ['AttitudePropagatorNode', 'LOG_EVERY_PERIODS', 'parameter_descriptor', 'ros_value']

#: Diagnostics periods between INFO log lines.
LOG_EVERY_PERIODS = 5

_GYRO_TOPICS = ('imu', 'angular_velocity')
_MESSAGE_TYPES = {'imu': Imu, 'angular_velocity': Vector3Stamped, 'torque': WrenchStamped,
                  'rotor_torque': Vector3Stamped, 'set_pose': PoseStamped,
                  'set_pose_with_covariance': PoseWithCovarianceStamped}


def parameter_descriptor(parameter: Parameter) -> ParameterDescriptor:
    """The ROS descriptor of a parameter of the table."""
    limits = []
    if parameter.type is float:
        low = parameter.low if parameter.low is not None else -float('inf')
        high = parameter.high if parameter.high is not None else float('inf')
        limits = [FloatingPointRange(from_value=low, to_value=high)]
    return ParameterDescriptor(
        name=parameter.name, description=parameter.description,
        read_only=parameter.read_only, floating_point_range=limits)


def ros_value(parameter: Parameter, value: Any) -> Any:
    """A parameter's value as the table takes it: a double array (rclpy gives a list or an
    ``array.array``, ``None`` when not set) as a tuple; other values as they are."""
    if parameter.type is not tuple:
        return value
    if value is None:
        return parameter.default
    return tuple(value) if isinstance(value, (list, tuple, array.array)) else value


class AttitudePropagatorNode(Node):
    """Feeds decoded messages to the scene's session and publishes what it produces.

    Keyword arguments go to :class:`rclpy.node.Node` (``context``, ``namespace``,
    ``parameter_overrides``, ``cli_args``, ...), so tests and tools can build the node
    in-process. Bad parameters or a bad scene raise :class:`InputError` or
    :class:`~rigid_body_attitude.core.errors.SceneError` from here. Every callback that touches
    the session holds :attr:`state_lock`, so the gyro loop of :func:`~.serve.main` and the
    executor thread serving the rest never interleave.
    """

    def __init__(self, **node_options: Any) -> None:
        """Declare the parameters, load the scene, create the session, topics and timers."""
        super().__init__(NODE_NAME, **node_options)
        #: The node clock in nanoseconds (receive times; ``use_sim_time`` makes it the
        #: ``/clock``).
        self.clock_ns = clock_nanoseconds(self.get_clock())
        self.state_lock = threading.Lock()
        values = self._declare_parameters()
        problem = check_values(values)
        if problem:
            raise InputError(problem)
        self.scene = load_node_scene(values['scene'], values['integrator'], values['step'],
                                     values['torque_timeout'])
        self.publish_rate: float = values['publish_rate']
        self.outputs = RosOutputs(self, self.scene.rate_source == 'gyro',
                                  values['covariance'])
        self.outputs.hardware_id = self.scene.name
        self.sim_clock = sim_clock_for(values, timer_period_ns(self.publish_rate), time.monotonic)
        self.session: AnySession = open_session(self.scene, values, self.outputs, (
            self.clock_ns if self.sim_clock is None else self.sim_clock.now), time.monotonic)
        problem = self.session.check(values) or sim_clock_problem(
            values, self.scene, getattr(self.session, 'command_inputs', ()))
        if problem:
            raise InputError(problem)
        if isinstance(self.session, DynamicsSession):
            self.session.sim_clock = self.sim_clock
        self.clock_publisher = (self.create_publisher(ClockMessage, '/clock', CLOCK_QOS)
                                if values['publish_clock'] else None)
        self.outputs.set_frames(values['world_frame'], values['body_frame'])
        self.outputs.log_queue.start()
        if values['publish_tf']:
            self.outputs.enable_tf(values['tf_rate'])
        imu = self.scene.imu
        if imu is not None:
            self.outputs.enable_simulated_imu(imu.topic, values['body_frame'], imu.frame_id,
                                              imu.mount())
        self._create_inputs()
        self._create_timers()
        self.reset_service = self.create_service(Trigger, '~/reset', self.reset_callback)
        self.add_on_set_parameters_callback(self.parameters_callback)
        self.add_post_set_parameters_callback(self.parameters_set_callback)
        self.get_logger().info(
            f'scene {self.scene.name!r} ({self.scene.rate_source}, {self.scene.integrator}'
            f'{", step %g s" % self.scene.step if self.is_dynamics else ""}): '
            f'{self.scene.description}')

    @property
    def is_dynamics(self) -> bool:
        """Whether the scene integrates Euler's equations (else gyro samples)."""
        return isinstance(self.session, DynamicsSession)

    # -- set-up -----------------------------------------------------------------------------

    def _declare_parameters(self) -> dict[str, Any]:
        values = {}
        for parameter in PARAMETERS:
            # A double array without a value ([]: not set) is declared by its type (an empty
            # list would make it a byte array); unset, it reads as the table's default.
            default = (RosParameter.Type.DOUBLE_ARRAY if parameter.type is tuple
                       else parameter.default)
            try:
                values[parameter.name] = ros_value(parameter, self.declare_parameter(
                    parameter.name, default, parameter_descriptor(parameter)).value)
            except InvalidParameterTypeException as err:
                raise InputError(f'Expected parameter `{parameter.name}` to be a '
                                 f'{parameter.type_text}: {str(err)[:200]}') from err
            except ParameterException as err:
                raise InputError(f'Bad parameter `{parameter.name}`: {str(err)[:200]}') from err
        return values

    def _create_inputs(self) -> None:
        """Raw subscriptions for the inputs the scene uses (and set_pose); ``/tf_static``
        for gyro scenes (the mount).

        The gyro subscriptions share a :class:`DedicatedGroup`, so :func:`~.serve.main`'s
        :class:`GyroLoop` can take them over (:meth:`gyro_loop`).
        """
        self.loop_group = DedicatedGroup()  # gyro subscriptions and the timers
        self.subscriptions_by_topic = {}
        self.takers: dict[str, Callable[[], bytes | None]] = {}
        self.handlers: dict[str, Callable[[bytes], None]] = {}
        self.mount_gate: MountGate | None = None
        session = self.session
        if isinstance(session, GyroSession):
            self.mount_gate = MountGate(session, self.get_parameter('tf_timeout').value,
                                        time.monotonic)
            self.tf_static_subscription = self.create_subscription(
                TFMessage, '/tf_static', self.tf_static_callback, TF_STATIC_LISTENER_QOS,
                raw=True)
        for topic in input_topics(self.scene, session.propagator.input_names):
            gyro = topic in _GYRO_TOPICS
            handler = self._gyro_handler(topic) if gyro else self._command_callback(topic)
            self.handlers[topic] = handler
            self.subscriptions_by_topic[topic] = self.create_subscription(
                _MESSAGE_TYPES[topic], topic, handler, GYRO_QOS if gyro else COMMAND_QOS,
                callback_group=self.loop_group if gyro or self.sim_clock else None,
                qos_overriding_options=QoSOverridingOptions.with_default_policies(), raw=True)
            self.takers[topic] = raw_taker(self.subscriptions_by_topic[topic])

    def _gyro_handler(self, topic: str) -> Callable[[bytes], None]:
        """The session's handler of a gyro ``topic`` (:func:`input_handler`) under the state
        lock, behind the mount gate until it opens."""
        handle, lock, gate = input_handler(self.session, topic), self.state_lock, self.mount_gate
        assert gate is not None

        def locked(data: bytes) -> None:
            with lock:
                if gate.open:
                    handle(data)
                else:
                    gate.sample(data, handle)
        return locked

    def _command_callback(self, topic: str) -> Callable[[bytes], None]:
        """The callback of a command ``topic``: it also takes every message queued behind the
        one it was given and hands only the newest decodable one to the session (the others
        are counted ``superseded``; malformed ones ``malformed``). On rclpy's stock path
        nothing more is taken: each message comes to the callback."""
        decode, handle = DECODERS[topic], input_handler(self.session, topic)
        session, lock = self.session, self.state_lock

        def coalesce(data: bytes) -> None:
            take = self.takers[topic]
            newest: bytes | None = None
            superseded = 0
            taken: bytes | None = data
            while taken is not None:
                try:
                    decode(taken)
                except MALFORMED:
                    with lock:
                        handle(taken)  # counted as malformed
                else:
                    superseded += newest is not None
                    newest = taken
                taken = take()
            with lock:
                if superseded:
                    session.rejections['superseded'] += superseded
                if newest is not None:
                    handle(newest)
        return coalesce

    def tf_static_callback(self, data: bytes) -> None:
        """Static transforms for the mount (:meth:`~.tf_lookup.MountGate.tf_static`)."""
        gate = self.mount_gate
        if gate is not None and not gate.open:
            gate.tf_static(data, self.state_lock)

    def _create_timers(self) -> None:
        """The output timer (node clock; dynamics scenes only) and the diagnostics timer
        (steady clock), in the loop group, so :func:`~.serve.main`'s gyro loop serves them (an
        executor rebuilds its wait set of every entity per tick: about 2.8 % of a core at
        50 Hz)."""
        self.output_timer = (self.create_timer(1.0 / self.publish_rate, self.tick_callback,
                                               self.loop_group)
                             if self.is_dynamics and self.sim_clock is None else None)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.diagnostics_timer = self.create_timer(
            DIAGNOSTICS_PERIOD, self.diagnostics_callback, self.loop_group, clock=steady)
        self._diagnostics_count = 0

    def gyro_loop(self) -> GyroLoop:
        """A :class:`GyroLoop` serving the gyro subscriptions (gyro scenes) and the timers (in
        :attr:`loop_group`); creating it takes them away from every executor. On the scene's
        own sim clock a :class:`StepLoop`, which also serves the commands."""
        if self.sim_clock is not None and isinstance(self.session, DynamicsSession):
            return step_loop(self.context, self.session, self.sim_clock, [
                (subscription, self.handlers[topic])
                for topic, subscription in self.subscriptions_by_topic.items()
                if topic in ('torque', 'rotor_torque')], [self.diagnostics_timer],
                self.clock_publisher, self.state_lock, self.outputs)
        return GyroLoop(self.context, [
            (self.subscriptions_by_topic[topic], self.handlers[topic])
            for topic in ('imu', 'angular_velocity') if topic in self.subscriptions_by_topic],
            [timer for timer in (self.output_timer, self.diagnostics_timer)
             if timer is not None])

    # -- parameters -------------------------------------------------------------------------

    def get_parameters_values(self) -> dict[str, Any]:
        """Current values of the node's own parameters by name."""
        return parameter_values(self)

    def parameters_callback(self, parameters: list[RosParameter]) -> SetParametersResult:
        """Refuse run-time values that the parameter table or the session finds unusable."""
        values = self.get_parameters_values()
        by_name = {p.name: p for p in PARAMETERS}
        values.update({p.name: ros_value(by_name[p.name], p.value) for p in parameters
                       if p.name in values})
        reason = self.session.check(values)
        return SetParametersResult(successful=not reason, reason=reason)

    def parameters_set_callback(self, parameters: list[RosParameter]) -> None:
        """Apply accepted run-time changes (frames, stamps, max_dt, thresholds)."""
        values = self.get_parameters_values()
        with self.state_lock:
            self.session.apply(values)
            self.outputs.set_frames(values['world_frame'], values['body_frame'])

    # -- services and timers ----------------------------------------------------------------

    def reset_callback(self, request: Trigger.Request,
                       response: Trigger.Response) -> Trigger.Response:
        """Back to the scene's initial state (gyro: the next sample is a new baseline)."""
        with self.state_lock:
            self.session.reset()
        response.success = True
        response.message = f'reset to the initial state of scene {self.scene.name!r}'
        self.outputs.log(LEVEL_INFO, response.message)
        return response

    def tick_callback(self) -> None:
        """The output timer of a dynamics scene: integrate up to the node clock, publish."""
        with self.state_lock:
            session = self.session
            if isinstance(session, DynamicsSession):
                session.tick(self.clock_ns())

    def diagnostics_callback(self) -> None:
        """Publish ``/diagnostics``; every :data:`LOG_EVERY_PERIODS` periods log a summary."""
        with self.state_lock:
            self.session.publish_diagnostics()
            self._diagnostics_count += 1
            if self._diagnostics_count % LOG_EVERY_PERIODS == 0:
                self.outputs.log(LEVEL_INFO, self.session.summary())

    def destroy_node(self) -> None:
        """Write the queued log lines (at most 1 s), then destroy the node."""
        self.outputs.log_queue.stop()
        super().destroy_node()  # type: ignore[no-untyped-call]


def parameter_values(node: Node) -> dict[str, Any]:
    """Current values of ``node``'s parameters of the table by name (``None``: a double
    array not set)."""
    values = {}
    for parameter in PARAMETERS:
        try:
            value = node.get_parameter(parameter.name).value
        except ParameterUninitializedException:  # a double array not set
            value = None
        values[parameter.name] = ros_value(parameter, value)
    return values
