"""The ``attitude_propagator`` node (executable ``propagation_node``): an rclpy shell.

Each callback converts a message to floats, hands them to the core's time rules
(:mod:`rigid_body_attitude.session.stream`) which advance the propagator
(:mod:`rigid_body_attitude.core.propagator`), and publishes the values of
:class:`~rigid_body_attitude.session.outputs.OutputTracker`. Nothing here integrates or decides
about time; the replay tool feeds the same core, so a replayed bag gives the same numbers.

* Gyro scenes advance on each ``imu`` (sensor_msgs/Imu) or ``angular_velocity``
  (geometry_msgs/Vector3Stamped) message and publish ``orientation``, ``pose`` and (for Imu
  input) ``imu/data`` per message, stamped with the gyro stamp. This is the hot path, so it
  handles serialized messages: the gyro subscriptions are raw, the stamp and rate are read
  from the CDR bytes and the outputs are written as CDR bytes with the header packed once
  (:mod:`rigid_body_attitude.bag.cdr`, the replay tool's codecs); outputs nobody subscribes
  to are not built. Spun in-process by any executor the node works as usual, one message per
  callback; :func:`main` serves it faster (below).
* Dynamics scenes advance on a timer of the node clock (``use_sim_time`` works) at
  ``publish_rate`` and publish ``orientation``, ``pose`` and ``twist`` per tick, stamped with
  the propagated time; commanded inputs arrive on ``torque`` (geometry_msgs/WrenchStamped)
  and ``rotor_torque`` (geometry_msgs/Vector3Stamped) when the scene takes them.
* ``energy`` and ``angular_momentum`` are published at ``publish_rate`` (decimated for gyro
  scenes); ``/diagnostics`` once a second, with an INFO log line every 5 s.
* ``set_pose`` re-initialises the attitude (and position); ``~/reset`` restores the scene's
  initial state.

Parameters and topics are documented in the README ("The node").

**The gyro loop.** rclpy's executors handle one message per wake-up and rebuild their wait set
each time (about 100 µs of Python per message with a ``SingleThreadedExecutor`` on this
project's machine); at kHz gyro rates that is the whole budget. :func:`main` therefore serves
gyro scenes with a :class:`GyroLoop` on the main thread: one reused ``rcl`` wait set holding
the gyro subscriptions and the node's two timers; after each wake-up it takes *every* queued
message of each subscription (``take_message`` on the raw subscription until it returns
None), hands the CDR bytes to the node's callback, then runs the timers that are due.
Everything else (parameter services, ``~/reset``, ``set_pose``) stays with a
``SingleThreadedExecutor`` in a second thread, which then sleeps in ``rcl_wait`` (GIL
released) nearly all the time; :attr:`AttitudePropagatorNode.state_lock` keeps the two
threads' changes of the state apart. The entities the loop serves belong to a
:class:`DedicatedGroup`: executors run them like any mutually exclusive group until a
:class:`GyroLoop` claims the group. The loop's wait set also holds rclpy's SIGINT guard
condition and one triggered on context shutdown or :meth:`GyroLoop.stop`, so it ends as
promptly as ``rclpy.spin``. :func:`main` also sets Fast DDS and the scheduler up for kHz
rates (:mod:`rigid_body_attitude.ros.middleware`). Measurements: ``docs/performance.md``,
``bench/NOTES.md``.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
import math
import threading
import time
from typing import Any

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (
    PoseStamped, QuaternionStamped, TwistStamped, Vector3Stamped, WrenchStamped)
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidParameterTypeException, ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos_overriding_options import QoSOverridingOptions
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from rigid_body_attitude.bag.cdr import (
    imu_with_orientation, pose_stamped_encoder, quaternion_stamped_encoder,
    RATE_SAMPLE_DECODERS)
from rigid_body_attitude.bag.msgtypes import IMU, VECTOR3_STAMPED
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.session.reports import (
    body_frame_velocity, diagnostic_report, LEVEL_ERROR, LEVEL_WARN,
    NANOSECONDS_PER_SECOND, stale_command_count, TimeBase)
from rigid_body_attitude.ros.gyro_loop import DedicatedGroup, GyroLoop
from rigid_body_attitude.ros.middleware import check_cpu_scheduling
from rigid_body_attitude.ros.qos import INPUT_QOS, OUTPUT_QOS
from rigid_body_attitude.session.outputs import OutputTracker
from rigid_body_attitude.core.propagator import (
    build_propagator, DynamicsPropagator, MAX_STEPS_PER_CALL)
from rigid_body_attitude.core.scene import Scene
from rigid_body_attitude.session.settings import (
    DIAGNOSTICS_PERIOD, load_node_scene, NODE_DEFAULTS, NODE_NAME, publishes)
from rigid_body_attitude.session.stream import ClockDriver, CommandStream, GyroStream, Outcome

__all__ = ['AttitudePropagatorNode', 'NodeSettings', 'RawOutput',
           'check_parameters']

#: Seconds between repeated warnings about the same rejection reason.
WARNING_INTERVAL = 5.0

#: Diagnostics periods (settings.DIAGNOSTICS_PERIOD, 1 s) between INFO log lines.
LOG_EVERY_PERIODS = 5

_LEVEL_BYTES = {0: DiagnosticStatus.OK, LEVEL_WARN: DiagnosticStatus.WARN,
                LEVEL_ERROR: DiagnosticStatus.ERROR}

#: Position published in the pose of gyro scenes (they carry no translation).
_ZERO_POSITION = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ParameterSpec:
    """One node parameter: description, range ``(min, max)`` or None, read-only.

    Defaults are :data:`rigid_body_attitude.session.settings.NODE_DEFAULTS` (shared with replay).
    """

    description: str
    limits: tuple[float, float] | None = None
    read_only: bool = True


PARAMETERS: dict[str, ParameterSpec] = {
    'scene': ParameterSpec('built-in scene name or path to a scene YAML file'),
    'world_frame': ParameterSpec('frame of pose, orientation and angular_momentum',
                                 read_only=False),
    'body_frame': ParameterSpec('frame of twist (the body)', read_only=False),
    'publish_rate': ParameterSpec('Hz: dynamics ticks; energy and angular_momentum output',
                                  (0.0, 1000.0)),
    'use_header_stamps': ParameterSpec('gyro and command times from header stamps (else the '
                                       'receive time on the node clock)', read_only=False),
    'constant_dt': ParameterSpec('s: integrate each gyro sample over this step (0 = stamps)',
                                 (0.0, 10.0), read_only=False),
    'max_dt': ParameterSpec('s: a longer gap between gyro samples is not integrated across',
                            (0.0, 3600.0), read_only=False),
    'time_jump_threshold': ParameterSpec('s: a larger backward jump of input stamps or node '
                                         'clock resets to the initial state', (0.0, 1.0e6),
                                         read_only=False),
    'torque_timeout': ParameterSpec('s: commands (torque, force, rotor torque) are held this '
                                    'long, then zeroed (0 = the scene\'s)', (0.0, 3600.0)),
    'integrator': ParameterSpec('integrator (dynamics) or strapdown method (gyro) overriding '
                                'the scene\'s ("" = the scene\'s)'),
    'step': ParameterSpec('s: integration step of dynamics scenes (0 = the scene\'s)',
                          (0.0, 10.0)),
    'cpu_scheduling': ParameterSpec('policy of the node\'s threads: batch (SCHED_BATCH, no '
                                    'wake-up preemption) or default (as started)'),
}

_TYPE_NAMES = {float: 'double (written with a decimal point, e.g. 50.0)',
               bool: 'boolean (true or false)', str: 'string'}
_POSITIVE = ('publish_rate', 'max_dt', 'time_jump_threshold')
_NONNEGATIVE = ('constant_dt', 'torque_timeout', 'step')


def check_parameters(values: Mapping[str, Any], dynamics_step: float = 0.0) -> str:
    """Why these node parameter values are unusable, or ``''`` when they are fine.

    Checks what the descriptors' types and ranges cannot: strictly positive values, finite
    numbers, non-empty names and distinct frames. With the ``dynamics_step`` [s] of a dynamics
    scene it also checks that a clock jump just below ``time_jump_threshold`` (integrated in
    one tick) stays within the propagator's :data:`MAX_STEPS_PER_CALL`.
    """
    for name in _POSITIVE:
        value = values[name]
        if not (math.isfinite(value) and value > 0.0):
            return f'Expected parameter `{name}` to be a finite number > 0, got {value!r}'
    for name in _NONNEGATIVE:
        value = values[name]
        if not (math.isfinite(value) and value >= 0.0):
            return f'Expected parameter `{name}` to be a finite number >= 0, got {value!r}'
    problem = check_cpu_scheduling(values['cpu_scheduling'])
    if problem:
        return problem
    for name in ('scene', 'world_frame', 'body_frame'):
        if not values[name].strip():
            return f'Expected parameter `{name}` to be a non-empty name, got {values[name]!r}'
    if values['world_frame'] == values['body_frame']:
        return (f'Expected `world_frame` and `body_frame` to differ, both are '
                f'{values["world_frame"]!r}')
    threshold = values['time_jump_threshold']
    if dynamics_step > 0.0 and threshold / dynamics_step > MAX_STEPS_PER_CALL:
        return (f'Expected parameter `time_jump_threshold` to be at most '
                f'{MAX_STEPS_PER_CALL * dynamics_step:g} s ({MAX_STEPS_PER_CALL} steps of '
                f'{dynamics_step:g} s in one tick), got {threshold!r}')
    return ''


@dataclass(frozen=True)
class NodeSettings:
    """What the read-only parameters fix at start: the scene (with overrides), the rate."""

    scene: Scene
    publish_rate: float


def _descriptor(name: str, spec: ParameterSpec) -> ParameterDescriptor:
    limits = ([FloatingPointRange(from_value=spec.limits[0], to_value=spec.limits[1])]
              if spec.limits else [])
    return ParameterDescriptor(name=name, description=spec.description,
                               read_only=spec.read_only, floating_point_range=limits)


def load_settings(values: Mapping[str, Any]) -> NodeSettings:
    """Load the scene with the parameter overrides; raises the project's errors."""
    problem = check_parameters(values)
    if problem:
        raise InputError(problem)
    scene = load_node_scene(values['scene'], values['integrator'], values['step'],
                            values['torque_timeout'])
    if scene.rate_source == 'dynamics':
        problem = check_parameters(values, scene.step)
        if problem:
            raise InputError(problem)
    return NodeSettings(scene, values['publish_rate'])


class AttitudePropagatorNode(Node):
    """Propagates the scene's attitude from gyro samples or Euler's equations and publishes it.

    Keyword arguments go to :class:`rclpy.node.Node` (``context``, ``namespace``,
    ``parameter_overrides``, ``cli_args``, ...), so tests and tools can build the node
    in-process. Bad parameters or a bad scene raise :class:`InputError` or
    :class:`~rigid_body_attitude.core.errors.SceneError` (or another project error) from here.

    Every callback that reads or changes the propagation state holds :attr:`state_lock`, so
    the gyro loop of :func:`main` and the executor thread serving the rest never interleave.
    """

    def __init__(self, **node_options: Any) -> None:
        """Declare the parameters, load the scene, create topics, timers and the service."""
        super().__init__(NODE_NAME, **node_options)
        self.state_lock = threading.Lock()
        values = self._declare_parameters()
        self.settings = load_settings(values)
        self.cpu_scheduling: str = values['cpu_scheduling']
        self.scene = self.settings.scene
        self.propagator = build_propagator(self.scene)
        self.is_dynamics = isinstance(self.propagator, DynamicsPropagator)
        self.time_base = TimeBase()
        self.output_tracker = OutputTracker()
        self.gyro_stream: GyroStream | None = None
        self.clock_driver: ClockDriver | None = None
        if self.is_dynamics:
            self.clock_driver = ClockDriver(self.propagator, values['time_jump_threshold'])
        else:
            self.gyro_stream = GyroStream(self.propagator, values['max_dt'],
                                          values['time_jump_threshold'])
        self.command_stream = CommandStream(self.propagator)
        self.shell_rejections: Counter[str] = Counter()  # set_pose, refused integrations
        self.input_messages = 0
        self._last_warning: dict[str, float] = {}
        self._create_outputs()
        self._apply_runtime_parameters(values)
        self._create_inputs()
        self._create_timers()
        self.reset_service = self.create_service(Trigger, '~/reset', self.reset_callback)
        self.add_on_set_parameters_callback(self.parameters_callback)
        self.add_post_set_parameters_callback(self.parameters_set_callback)
        self.get_logger().info(
            f'scene {self.scene.name!r} ({self.scene.rate_source}, {self.scene.integrator}'
            f'{", step %g s" % self.scene.step if self.is_dynamics else ""}): '
            f'{self.scene.description}')

    # -- set-up ---------------------------------------------------------------------------

    def _declare_parameters(self) -> dict[str, Any]:
        values = {}
        for name, spec in PARAMETERS.items():
            try:
                values[name] = self.declare_parameter(
                    name, NODE_DEFAULTS[name], _descriptor(name, spec)).value
            except InvalidParameterTypeException as err:
                raise InputError(f'Expected parameter `{name}` to be a '
                                 f'{_TYPE_NAMES[type(NODE_DEFAULTS[name])]}: {err}') from err
            except ParameterException as err:
                raise InputError(f'Bad parameter `{name}`: {err}') from err
        return values

    def _apply_runtime_parameters(self, values: Mapping[str, Any]) -> None:
        """Take the parameters that may change at run time."""
        self.use_header_stamps = values['use_header_stamps']
        self.world_header.frame_id = values['world_frame']
        self.encode_orientation = quaternion_stamped_encoder(values['world_frame'])
        self.encode_pose = pose_stamped_encoder(values['world_frame'])
        self.twist_message.header.frame_id = values['body_frame']
        if self.clock_driver is not None:
            self.clock_driver.time_jump_threshold = values['time_jump_threshold']
        if self.gyro_stream is not None:
            self.gyro_stream.max_dt = values['max_dt']
            self.gyro_stream.time_jump_threshold = values['time_jump_threshold']
            self.gyro_stream.constant_dt = values['constant_dt']

    def _publisher(self, message_type: Any, topic: str) -> Any:
        return self.create_publisher(
            message_type, topic, OUTPUT_QOS,
            qos_overriding_options=QoSOverridingOptions.with_default_policies())

    def _subscription(self, message_type: Any, topic: str, callback: Any,
                      gyro_group: DedicatedGroup | None = None) -> Any:
        """A subscription; with ``gyro_group`` a raw one (CDR bytes) in that group."""
        return self.create_subscription(
            message_type, topic, callback, INPUT_QOS,
            qos_overriding_options=QoSOverridingOptions.with_default_policies(),
            callback_group=gyro_group, raw=gyro_group is not None)

    def _create_outputs(self) -> None:
        """Publishers and the messages they reuse (only the stamp and values change)."""
        self.orientation_publisher = self._publisher(QuaternionStamped, 'orientation')
        self.pose_publisher = self._publisher(PoseStamped, 'pose')
        self.energy_publisher = self._publisher(Float64, 'energy')
        self.momentum_publisher = self._publisher(Vector3Stamped, 'angular_momentum')
        self.diagnostics_publisher = self.create_publisher(
            DiagnosticArray, '/diagnostics', OUTPUT_QOS)
        if self.is_dynamics:
            self.twist_publisher = self._publisher(TwistStamped, 'twist')
        else:  # gyro-rate outputs, published as CDR bytes
            self.imu_publisher = self._publisher(Imu, 'imu/data')
            self.orientation_raw = RawOutput(self.orientation_publisher)
            self.pose_raw = RawOutput(self.pose_publisher)
            self.imu_raw = RawOutput(self.imu_publisher)
        # Messages built once; pose, orientation and angular_momentum share one header
        # (world frame, output stamp) and pose shares the orientation's quaternion.
        self.orientation_message = QuaternionStamped()
        self.world_header = self.orientation_message.header
        self.pose_message = PoseStamped(header=self.world_header)
        self.pose_message.pose.orientation = self.orientation_message.quaternion
        self.momentum_message = Vector3Stamped(header=self.world_header)
        self.energy_message = Float64()
        self.twist_message = TwistStamped()
        self._fresh_output = False
        self._output_stamp = (0, 0)  # (sec, nanosec) of the last gyro output

    def get_parameters_values(self) -> dict[str, Any]:
        """Current values of the node's own parameters by name."""
        return {name: self.get_parameter(name).value for name in PARAMETERS}

    def _create_inputs(self) -> None:
        """Subscriptions for the inputs the scene uses (and set_pose).

        The gyro subscriptions are raw and share a :class:`DedicatedGroup`, so :func:`main`'s
        :class:`GyroLoop` can take them over (:meth:`gyro_handlers`).
        """
        self.subscriptions_by_topic = {}
        self.gyro_group: DedicatedGroup | None = None
        if not self.is_dynamics:
            self.gyro_group = DedicatedGroup()
            self._decode_imu = RATE_SAMPLE_DECODERS[IMU]
            self._decode_rate = RATE_SAMPLE_DECODERS[VECTOR3_STAMPED]
            self.subscriptions_by_topic['imu'] = self._subscription(
                Imu, 'imu', self.imu_callback, self.gyro_group)
            self.subscriptions_by_topic['angular_velocity'] = self._subscription(
                Vector3Stamped, 'angular_velocity', self.angular_velocity_callback,
                self.gyro_group)
        inputs = self.propagator.input_names
        self.wrench_inputs = tuple(name for name in ('torque', 'force') if name in inputs)
        if self.wrench_inputs:
            self.subscriptions_by_topic['torque'] = self._subscription(
                WrenchStamped, 'torque', self.torque_callback)
        if 'rotor_torque' in inputs:
            self.subscriptions_by_topic['rotor_torque'] = self._subscription(
                Vector3Stamped, 'rotor_torque', self.rotor_torque_callback)
        self.subscriptions_by_topic['set_pose'] = self._subscription(
            PoseStamped, 'set_pose', self.set_pose_callback)

    def _create_timers(self) -> None:
        """The output timer (node clock) and the diagnostics timer (steady clock); for gyro
        scenes in the gyro group, so :func:`main`'s gyro loop serves them too."""
        self.output_timer = self.create_timer(1.0 / self.settings.publish_rate,
                                              self.tick_callback, self.gyro_group)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.diagnostics_timer = self.create_timer(
            DIAGNOSTICS_PERIOD, self.diagnostics_callback, self.gyro_group, clock=steady)
        self._diagnostics_count = 0
        self._period_start = time.monotonic()
        self._period_start_inputs = 0
        self._period_rejections: Counter[str] = Counter()

    # -- parameters -----------------------------------------------------------------------

    def parameters_callback(self, parameters: list[Parameter]) -> SetParametersResult:
        """Refuse run-time values that :func:`check_parameters` finds unusable."""
        values = self.get_parameters_values()
        values.update({p.name: p.value for p in parameters if p.name in PARAMETERS})
        reason = check_parameters(values, self.scene.step if self.is_dynamics else 0.0)
        return SetParametersResult(successful=not reason, reason=reason)

    def parameters_set_callback(self, parameters: list[Parameter]) -> None:
        """Apply accepted run-time changes (frames, stamps, max_dt, thresholds)."""
        values = self.get_parameters_values()
        with self.state_lock:
            self._apply_runtime_parameters(values)

    # -- inputs ---------------------------------------------------------------------------

    def gyro_loop(self) -> GyroLoop | None:
        """A :class:`GyroLoop` serving the gyro subscriptions and the timers (None for
        dynamics scenes); creating it takes them away from every executor."""
        if self.is_dynamics:
            return None
        return GyroLoop(self.context, [
            (self.subscriptions_by_topic['imu'], self.imu_callback),
            (self.subscriptions_by_topic['angular_velocity'], self.angular_velocity_callback),
        ], [self.output_timer, self.diagnostics_timer])

    def imu_callback(self, imu_cdr: bytes) -> None:
        """Propagate with a serialized Imu's angular velocity; publish it back with the
        orientation filled in (``imu/data``)."""
        sec, nanosec, rate = self._decode_imu(imu_cdr)
        with self.state_lock:
            attitude = self._gyro_sample(sec, nanosec, rate)
            if attitude is not None:
                # REP-145: orientation covariance all zeros = unknown (not -1: provided).
                if self.imu_raw.subscription_count():
                    self.imu_raw.publish(imu_with_orientation(imu_cdr, attitude))

    def angular_velocity_callback(self, rate_cdr: bytes) -> None:
        """Propagate with a serialized Vector3Stamped body rate."""
        sec, nanosec, rate = self._decode_rate(rate_cdr)
        with self.state_lock:
            self._gyro_sample(sec, nanosec, rate)

    def torque_callback(self, wrench: WrenchStamped) -> None:
        """Hold the commanded torque (and force, with translation) from the stamp on."""
        torque, force = wrench.wrench.torque, wrench.wrench.force
        vectors = {'torque': (torque.x, torque.y, torque.z),
                   'force': (force.x, force.y, force.z)}
        with self.state_lock:
            self._command(self.wrench_inputs, self._command_time(wrench.header.stamp), vectors)

    def rotor_torque_callback(self, rotor_torque: Vector3Stamped) -> None:
        """Hold the commanded motor torque on the rotor from the stamp on."""
        vector = rotor_torque.vector
        with self.state_lock:
            self._command(('rotor_torque',), self._command_time(rotor_torque.header.stamp),
                          {'rotor_torque': (vector.x, vector.y, vector.z)})

    def set_pose_callback(self, pose: PoseStamped) -> None:
        """Re-initialise the attitude (and the position, when the scene has translation)."""
        o, p = pose.pose.orientation, pose.pose.position
        attitude, position = (o.w, o.x, o.y, o.z), (p.x, p.y, p.z)
        with self.state_lock:
            self.input_messages += 1
            if not all(math.isfinite(value) for value in attitude + position):
                self._reject_pose('non_finite', attitude + position)
                return
            try:
                self.propagator.set_attitude(
                    attitude, position if self.propagator.has_translation else None)
            except InputError as err:
                self._reject_pose('invalid_pose', str(err))
                return
        where = f', position {position}' if self.propagator.has_translation else ''
        self.get_logger().info(f'set_pose: attitude (w, x, y, z) {attitude}{where}')

    def reset_callback(self, request: Trigger.Request,
                       response: Trigger.Response) -> Trigger.Response:
        """Back to the scene's initial state (gyro: the next sample is a new baseline)."""
        with self.state_lock:
            self._reset_state()
        response.success = True
        response.message = f'reset to the initial state of scene {self.scene.name!r}'
        self.get_logger().info(response.message)
        return response

    def _reset_state(self) -> None:
        """The scene's initial state; gyro: the next sample is a baseline, dynamics: the next
        tick restarts the scene at the clock's time."""
        if self.gyro_stream is not None:
            self.gyro_stream.reset()
        else:
            self.clock_driver.reset()
            self.propagator.reset(self.propagator.state.time)
        self.command_stream.reset()

    def _gyro_sample(self, sec: int, nanosec: int, rate: tuple[float, ...]
                     ) -> tuple[float, float, float, float] | None:
        """Feed one gyro sample stamped ``(sec, nanosec)`` to the stream; if the state moved,
        publish orientation and pose and return the attitude (w, x, y, z), else None.

        Called with :attr:`state_lock` held.
        """
        self.input_messages += 1
        if not self.use_header_stamps:
            sec, nanosec = divmod(self.get_clock().now().nanoseconds, NANOSECONDS_PER_SECOND)
        outcome = self.gyro_stream.add(self.time_base.seconds(sec, nanosec), rate)
        if outcome.reason:
            self._rejected('gyro', outcome, sec == 0 and nanosec == 0)
            if not publishes(outcome):
                return None
        attitude = self.output_tracker.attitude(self.propagator)
        orientation, pose = self.orientation_raw, self.pose_raw
        if orientation.subscription_count():
            orientation.publish(self.encode_orientation(sec, nanosec, attitude))
        if pose.subscription_count():
            pose.publish(self.encode_pose(sec, nanosec, _ZERO_POSITION, attitude))
        self._output_stamp = (sec, nanosec)
        self._fresh_output = True
        return attitude

    def _command_time(self, stamp: Time) -> float:
        """The command's time: its stamp, or the receive time (no header stamps, zero stamp)."""
        if self.use_header_stamps and (stamp.sec or stamp.nanosec):
            return self.time_base.seconds(stamp.sec, stamp.nanosec)
        return self.time_base.seconds_from_nanoseconds(self.get_clock().now().nanoseconds)

    def _command(self, names: tuple[str, ...], t: float,
                 vectors: Mapping[str, tuple[float, float, float]]) -> None:
        """Pass one message's commands on; a non-finite field rejects the whole message."""
        self.input_messages += 1
        bad = [name for name in names if not all(math.isfinite(v) for v in vectors[name])]
        for name in bad[:1] or names:
            outcome = self.command_stream.add(name, t, vectors[name])
            if outcome.reason:
                self._rejected(name, outcome, False)
                return

    def _integration_failed(self, err: AttitudeError) -> None:
        """Count a refused integration, log it and restart the scene at the next tick."""
        self.shell_rejections['integration_failed'] += 1
        self._period_rejections['integration_failed'] += 1
        self.get_logger().error(f'integration refused at t={self.propagator.state.time:.6f} s: '
                                f'{err}; reset to the initial state of scene '
                                f'{self.scene.name!r}')
        self._reset_state()

    def _reject_pose(self, reason: str, detail: Any) -> None:
        self.shell_rejections[reason] += 1
        self._period_rejections[reason] += 1
        self._warn(reason, f'set_pose rejected ({reason}): {detail}')

    # -- outputs --------------------------------------------------------------------------

    def tick_callback(self) -> None:
        """Dynamics: integrate up to the node clock and publish; gyro: energy and momentum."""
        with self.state_lock:
            self._tick()

    def _tick(self) -> None:
        if self.clock_driver is None:
            if self._fresh_output:
                sec, nanosec = self._output_stamp
                self.world_header.stamp = Time(sec=sec, nanosec=nanosec)
                self._publish_invariants()
            return
        now = self.get_clock().now().nanoseconds
        try:
            outcome = self.clock_driver.tick(self.time_base.seconds_from_nanoseconds(now))
        except AttitudeError as err:  # the integrator refused the step; the state is intact
            self._integration_failed(err)
            return
        if outcome.reason:
            self._rejected('clock', outcome, False)
            if outcome.reset:
                self.command_stream.reset()
            if not publishes(outcome):
                return
        self._publish_dynamics()

    def _publish_attitude(self, stamp: Time, qx: float, qy: float, qz: float,
                          qw: float) -> None:
        """Publish ``orientation`` and ``pose`` (position from the state) at ``stamp``."""
        self.world_header.stamp = stamp
        q = self.orientation_message.quaternion
        q.x, q.y, q.z, q.w = qx, qy, qz, qw
        self.orientation_publisher.publish(self.orientation_message)
        self.pose_publisher.publish(self.pose_message)

    def _publish_dynamics(self) -> None:
        """Publish every output of a dynamics scene at the propagated time."""
        sample = self.output_tracker.sample(self.propagator)
        sec, nanosec = self.time_base.stamp(sample.stamp)
        stamp = Time(sec=sec, nanosec=nanosec)
        position = self.pose_message.pose.position
        position.x, position.y, position.z = sample.position
        qw, qx, qy, qz = sample.attitude
        self._publish_attitude(stamp, qx, qy, qz, qw)
        twist = self.twist_message
        twist.header.stamp = stamp
        angular, linear = twist.twist.angular, twist.twist.linear
        angular.x, angular.y, angular.z = sample.omega_body
        linear.x, linear.y, linear.z = body_frame_velocity(self.propagator)
        self.twist_publisher.publish(twist)
        self._publish_invariants(sample.energy, sample.world_momentum)

    def _publish_invariants(self, energy: float | None = None,
                            world_momentum: tuple[float, float, float] | None = None) -> None:
        """Publish ``energy`` and ``angular_momentum`` at the last output stamp (each only
        when subscribed: gyro scenes compute them here, at ``publish_rate``)."""
        self._fresh_output = False
        if _listened(self.energy_publisher):
            self.energy_message.data = self.propagator.energy() if energy is None else energy
            self.energy_publisher.publish(self.energy_message)
        if _listened(self.momentum_publisher):
            if world_momentum is None:
                world_momentum = tuple(self.propagator.world_momentum().tolist())
            momentum = self.momentum_message
            momentum.vector.x, momentum.vector.y, momentum.vector.z = world_momentum
            self.momentum_publisher.publish(momentum)

    # -- rejections and diagnostics -------------------------------------------------------

    def _rejected(self, source: str, outcome: Outcome, zero_stamp: bool) -> None:
        """Count and report a rejection (a time jump once per jump, others throttled);
        ``zero_stamp``: the message had a zero header stamp (hinted at in the warning)."""
        self._period_rejections[outcome.reason] += 1
        if outcome.reset:
            self.get_logger().warning(
                f'{source}: time jumped back by more than {self._time_jump_threshold()} s '
                f'(looping bag?); reset to the initial state of scene {self.scene.name!r}')
            return
        detail = {
            'non_finite': 'a non-finite value (NaN or Inf); message ignored',
            'stale_stamp': 'a stamp not newer than the last one; message ignored',
            'gap': 'a gap longer than max_dt; not integrated across, attitude held',
        }[outcome.reason]
        hint = ''
        if zero_stamp:
            hint = ' (zero header stamps: set use_header_stamps:=false)'
        self._warn(outcome.reason, f'{source}: {detail}{hint}')

    def _time_jump_threshold(self) -> float:
        return self.get_parameter('time_jump_threshold').value

    def _warn(self, reason: str, text: str) -> None:
        """A warning per rejection reason at most every :data:`WARNING_INTERVAL` seconds."""
        now = time.monotonic()
        if now - self._last_warning.get(reason, -math.inf) >= WARNING_INTERVAL:
            self._last_warning[reason] = now
            total = self.rejection_counts()[reason]
            self.get_logger().warning(f'{text} [{total} rejected so far]')

    def rejection_counts(self) -> Counter[str]:
        """Rejected inputs so far by reason (:data:`REJECTION_KEYS`)."""
        counts: Counter[str] = Counter()
        for stream in (self.gyro_stream, self.clock_driver, self.command_stream):
            if stream is not None:
                counts.update(stream.rejected)
        counts.update(self.shell_rejections)
        counts['stale_torque'] = stale_command_count(self.propagator.counters())
        return counts

    def accepted_count(self) -> int:
        """Inputs used so far (gyro samples or commands, and clock ticks)."""
        return sum(stream.accepted for stream in (self.gyro_stream, self.clock_driver,
                                                  self.command_stream) if stream is not None)

    def _step_text(self) -> str:
        if self.is_dynamics:
            return f'{self.scene.step:g}'
        constant_dt = self.gyro_stream.constant_dt
        return f'{constant_dt:g} (constant_dt)' if constant_dt > 0.0 else 'gyro stamps'

    def diagnostics_callback(self) -> None:
        """Publish ``/diagnostics``; every :data:`LOG_EVERY_PERIODS` periods log a summary."""
        with self.state_lock:
            self._diagnostics()

    def _diagnostics(self) -> None:
        now, inputs = time.monotonic(), self.input_messages
        rate = (inputs - self._period_start_inputs) / max(now - self._period_start, 1e-9)
        self._period_start_inputs, self._period_start = inputs, now
        report = diagnostic_report(self.propagator, self.rejection_counts(),
                                   self._period_rejections, self.accepted_count(), rate,
                                   self._step_text())
        self._period_rejections = Counter()
        status = DiagnosticStatus(
            level=_LEVEL_BYTES[report.level], name=f'{self.get_fully_qualified_name()}',
            message=report.message, hardware_id=self.scene.name,
            values=[KeyValue(key=key, value=value) for key, value in report.values])
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_publisher.publish(array)
        self._diagnostics_count += 1
        if self._diagnostics_count % LOG_EVERY_PERIODS == 0:
            self._log_summary(rate)

    def _log_summary(self, rate: float) -> None:
        diagnostics = self.propagator.diagnostics()
        rejected = sum(self.rejection_counts().values())
        self.get_logger().info(
            f't={self.propagator.state.time:.3f} s: energy {diagnostics.kinetic_energy:.9g} J '
            f'(drift {diagnostics.energy_drift:.2e}, balance residual '
            f'{diagnostics.energy_balance_residual:.2e} J), |H| '
            f'{math.sqrt(sum(h * h for h in diagnostics.world_angular_momentum)):.9g} N m s '
            f'(drift {diagnostics.momentum_drift:.2e}), inputs {rate:.1f} Hz, '
            f'rejected {rejected}')


def _listened(publisher: Any) -> bool:
    """Whether an output is worth building and publishing: a subscription is matched.

    Outputs are VOLATILE (``qos_overrides`` cannot change durability), so a sample published
    with no matched subscription reaches nobody, ever; Fast DDS still stores it in the
    writer's history, about 10 µs per message on this machine with a cold cache (1 kHz),
    against about 2 µs for the count (docs/performance.md).
    """
    return publisher.get_subscription_count() > 0


class RawOutput:
    """A gyro-rate output: its subscription count and CDR-bytes publish, bound once.

    Both go straight to rclpy's publisher handle, without :class:`rclpy.publisher.Publisher`'s
    per-call wrapper (it enters the handle as a context manager, against destruction by
    another thread, and checks the message type). That is safe here because the node's
    publishers are destroyed only after its gyro loop has returned. Publish only when
    :meth:`subscription_count` is non-zero (see :func:`_listened`).
    """

    __slots__ = ('subscription_count', 'publish')

    def __init__(self, publisher: Any) -> None:
        """Bind ``publisher``'s handle."""
        handle = publisher.handle
        #: Matched subscriptions now (``int``; call it).
        self.subscription_count: Callable[[], int] = handle.get_subscription_count
        #: Publish serialized (CDR) ``bytes``.
        self.publish: Callable[[bytes], None] = handle.publish_raw
