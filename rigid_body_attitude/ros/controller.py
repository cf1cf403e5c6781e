"""The ``attitude_controller`` node: quaternion-feedback PD over ROS, an rclpy adapter.

Subscribes (raw CDR, decoded by the package's checked decoders) to ``odom``
(nav_msgs/Odometry: the pose in world_frame, the twist in body_frame) or, with
``state_input`` ``orientation_twist``, to ``orientation`` (geometry_msgs/QuaternionStamped,
world_frame) and ``twist`` (geometry_msgs/TwistStamped, the angular part in body_frame); and to
``target`` (geometry_msgs/QuaternionStamped, world_frame). Publishes ``torque``
(geometry_msgs/WrenchStamped, body_frame, zero force), or with ``actuator``
``reaction_wheels`` the scene's wheels' motor torques on ``wheels/command``
(sensor_msgs/JointState; :class:`~rigid_body_attitude.session.wheel_drive.WheelDrive`), and
``/diagnostics``. With torque rods (``actuator`` ``magnetorquers``: B-dot; or the wheels'
scene's commanded rods: dumping) it publishes ``dipole`` (geometry_msgs/Vector3Stamped) and
reads the magnetometer (``imu/mag``, sensor_msgs/MagneticField), the plant's ``wheels/state``
(dumping) and ``/tf_static`` (the magnetometer's mount;
:mod:`~rigid_body_attitude.session.magnetic_control`). Remap ``odom`` to read an estimator
(robot_localization's ``odometry/filtered``) instead of the plant's truth. The inputs are
served by the package's raw-take loop
(:class:`~rigid_body_attitude.ros.raw_take_loop.RawTakeLoop`, every queued message per wake-up) and
the parameter services by an executor in a second thread; on rclpy's stock executor path
(:mod:`~rigid_body_attitude.ros.rclpy_internals`) one executor serves all. Everything else
(pairing by stamp, sample and hold, checks, counts) is
:class:`~rigid_body_attitude.session.controller.ControllerSession`'s. QoS: inputs as the
propagation node's commands, ``torque`` reliable, keep last and transient local
(:mod:`~rigid_body_attitude.ros.qos`), so the two connect either way round and a recorder
that matches late still gets every command.
"""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

import rclpy

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter
from rcl_interfaces.msg import SetParametersResult

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.cdr import encode_vector3_stamped, stamped_floats_encoder
from rigid_body_attitude.msgs.decoders import (
    decode_magnetic_field, decode_quaternion_stamped, decode_twist_stamped)
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.msgs.joint_state import decode_joint_state
from rigid_body_attitude.msgs.odometry import decode_odometry
from rigid_body_attitude.msgs.tf_message import decode_tf_message
from rigid_body_attitude.ros.cli_help import format_parameter_help, ParameterRow
from rigid_body_attitude.ros.parameters import (
    declare_retired_parameters, declare_table_parameter, parameter_values, ros_value)
from rigid_body_attitude.ros.raw_take_loop import DedicatedGroup, RawTakeLoop
from rigid_body_attitude.ros.diagnostics import DiagnosticsPublisher
from rigid_body_attitude.ros.interface import create_publisher, create_subscription
from rigid_body_attitude.ros.rclpy_internals import fast_path_problem, raw_output
from rigid_body_attitude.ros.serve import run_executable, serve_beside_executor, SERVING_LINE
from rigid_body_attitude.session.controller import ControllerSession
from rigid_body_attitude.session.controller_parameters import (
    CONTROLLER_PARAMETERS, check_controller_values, RENAMED_CONTROLLER_PARAMETERS,
    renamed_problem, STATE_INPUTS)
from rigid_body_attitude.session.interface import CONTROLLER_INTERFACE
from rigid_body_attitude.session.magnetic_control import magnetic_control
from rigid_body_attitude.session.reports import DiagnosticReport, LEVEL_WARN
from rigid_body_attitude.session.settings import DIAGNOSTICS_PERIOD, load_node_scene
from rigid_body_attitude.session.wheel_drive import WheelDrive

__all__ = ['AttitudeControllerNode', 'CONTROLLER_NODE_NAME', 'controller_usage', 'main']

CONTROLLER_NODE_NAME = 'attitude_controller'
_ZERO_FORCE = (0.0, 0.0, 0.0)


class AttitudeControllerNode(Node):
    """Answers each tick's state (``odom``, or ``orientation`` and ``twist``) with a ``torque``
    of the same stamp.

    Keyword arguments go to :class:`rclpy.node.Node` (``context``, ``namespace``,
    ``parameter_overrides``, ``cli_args``, ...), e.g.
    ``AttitudeControllerNode(parameter_overrides=[Parameter('kp', value=0.2)])``. Bad parameter
    values raise :class:`InputError`.
    """

    def __init__(self, **node_options: Any) -> None:
        """Declare and check the parameters, create the session, topics and timer."""
        super().__init__(CONTROLLER_NODE_NAME, **node_options)
        values = self._declare_parameters()
        problem = check_controller_values(values)
        if problem:
            raise InputError(problem)
        scene = load_node_scene(values['scene']) if values['scene'] else None
        #: ``actuator`` ``reaction_wheels``: the scene's wheel array the torque drives.
        self.wheel_drive = (WheelDrive(scene) if values['actuator'] == 'reaction_wheels'
                            and scene is not None else None)
        magnetic = magnetic_control(values, scene, self.wheel_drive)
        self.session = ControllerSession(values, self, time.monotonic, magnetic)
        #: The inputs and the diagnostics timer: served by :meth:`loop`'s raw-take loop (or,
        #: on rclpy's stock executor, as any callback group); the parameter callbacks run in
        #: the executor's thread, so the session is changed under this lock.
        self.loop_group = DedicatedGroup()
        self.session_lock = threading.Lock()
        self._create_command_publishers()
        #: ``torque``'s CDR publish (``None`` with wheels) and its encoders by body_frame.
        self._publish_torque = (None if self.torque_publisher is None
                                else raw_output(self.torque_publisher)[1])
        self._encoders: dict[str, Any] = {}
        self.diagnostics_publisher = DiagnosticsPublisher(self, CONTROLLER_INTERFACE,
                                                          CONTROLLER_NODE_NAME)
        callbacks = {'odometry': self.odometry_callback, 'attitude': self.orientation_callback,
                     'twist': self.twist_callback, 'target': self.target_callback,
                     'magnetic_field': self.magnetometer_callback,
                     'wheel_state': self.wheel_state_callback,
                     'transforms': self.tf_static_callback}
        wanted = (*STATE_INPUTS[values['state_input']], 'target',
                  *(magnetic.inputs if magnetic else ()))
        #: (subscription, callback) of each input of :data:`CONTROLLER_INTERFACE` that
        #: ``state_input`` and the torque rods ask for.
        self.inputs = [
            (create_subscription(self, endpoint, callbacks[endpoint.quantity], self.loop_group),
             callbacks[endpoint.quantity])
            for endpoint in CONTROLLER_INTERFACE
            if endpoint.direction == 'in' and endpoint.quantity in wanted]
        self.diagnostics_timer = self.create_timer(
            DIAGNOSTICS_PERIOD, self.diagnostics_callback, self.loop_group,
            clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.add_on_set_parameters_callback(self.parameters_callback)
        self.add_post_set_parameters_callback(self.parameters_set_callback)

    def _create_command_publishers(self) -> None:
        """``torque``, or (``actuator`` ``reaction_wheels``) ``wheels/command``; ``dipole``
        with torque rods."""
        def publisher(name: str) -> Any:
            return create_publisher(self, CONTROLLER_INTERFACE.endpoint(name, 'out'))
        drive, session = self.wheel_drive, self.session
        self.torque_publisher = (publisher('torque') if drive is None and session.torque_out
                                 else None)
        self.wheels_publisher = None if drive is None else publisher('wheels/command')
        self.dipole_publisher = publisher('dipole') if session.magnetic is not None else None

    def _declare_parameters(self) -> dict[str, Any]:
        values = {parameter.name: declare_table_parameter(self, parameter)
                  for parameter in CONTROLLER_PARAMETERS}
        declare_retired_parameters(self, RENAMED_CONTROLLER_PARAMETERS, renamed_problem)
        return values

    def parameter_values(self) -> dict[str, Any]:
        """Current values of the controller's parameters by name."""
        return parameter_values(self, CONTROLLER_PARAMETERS)

    def parameters_callback(self, parameters: list[RosParameter]) -> SetParametersResult:
        """Refuse run-time values the parameter table finds unusable."""
        retired = [p.name for p in parameters if p.name in RENAMED_CONTROLLER_PARAMETERS
                   and p.value is not None]
        if retired:
            return SetParametersResult(successful=False, reason=renamed_problem(retired[0]))
        values = self.parameter_values()
        by_name = {p.name: p for p in CONTROLLER_PARAMETERS}
        values.update({p.name: ros_value(by_name[p.name], p.value) for p in parameters
                       if p.name in by_name})
        reason = check_controller_values(values)
        return SetParametersResult(successful=not reason, reason=reason)

    def parameters_set_callback(self, parameters: list[RosParameter]) -> None:
        """Apply accepted run-time changes (frames, target, gains, limit, period)."""
        values = self.parameter_values()
        with self.session_lock:
            self.session.apply(values)

    def loop(self) -> RawTakeLoop:
        """The package's raw-take loop serving the inputs and the diagnostics timer (one
        reused wait set, every queued message taken per wake-up); creating it takes them
        away from every executor."""
        return RawTakeLoop(self.context, self.inputs, [self.diagnostics_timer])

    def diagnostics_callback(self) -> None:
        """Publish this period's diagnostics."""
        with self.session_lock:
            self.session.publish_diagnostics()

    # -- inputs (raw CDR) -------------------------------------------------------------------

    def odometry_callback(self, data: bytes) -> None:
        """``odom``: the plant's attitude and body rate in one message."""
        try:
            odometry = decode_odometry(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('odom', err.reason)
            return
        with self.session_lock:
            self.session.odometry(odometry.sec, odometry.nanosec, odometry.frame_id,
                                  odometry.child_frame_id, odometry.orientation,
                                  odometry.angular)

    def orientation_callback(self, data: bytes) -> None:
        """``orientation``: the plant's attitude."""
        try:
            sec, nanosec, frame_id, attitude = decode_quaternion_stamped(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('orientation', err.reason)
            return
        with self.session_lock:
            self.session.orientation(sec, nanosec, frame_id, attitude)

    def twist_callback(self, data: bytes) -> None:
        """``twist``: the plant's body rate (the angular part)."""
        try:
            sec, nanosec, frame_id, _, angular = decode_twist_stamped(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('twist', err.reason)
            return
        with self.session_lock:
            self.session.twist(sec, nanosec, frame_id, angular)

    def magnetometer_callback(self, data: bytes) -> None:
        """``imu/mag``: a magnetometer sample."""
        try:
            sec, nanosec, frame_id, field, _ = decode_magnetic_field(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('imu/mag', err.reason)
            return
        with self.session_lock:
            self.session.magnetometer(sec, nanosec, frame_id, field)

    def wheel_state_callback(self, data: bytes) -> None:
        """``wheels/state``: the plant's wheel speeds."""
        try:
            state = decode_joint_state(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('wheels/state', err.reason)
            return
        with self.session_lock:
            self.session.wheel_state(state.sec, state.nanosec, state.names, state.velocity)

    def tf_static_callback(self, data: bytes) -> None:
        """``/tf_static``: the magnetometer's mount."""
        try:
            transforms = decode_tf_message(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('/tf_static', err.reason)
            return
        with self.session_lock:
            self.session.transforms(transforms)

    def target_callback(self, data: bytes) -> None:
        """``target``: a new target attitude."""
        try:
            sec, nanosec, frame_id, attitude = decode_quaternion_stamped(data)
        except MalformedMessage as err:
            with self.session_lock:
                self.session.malformed('target', err.reason)
            return
        with self.session_lock:
            self.session.target_message(sec, nanosec, frame_id, attitude)

    # -- the session's sink -----------------------------------------------------------------

    def torque(self, sec: int, nanosec: int, torque_body: tuple[float, float, float]) -> None:
        """Publish ``torque`` stamped ``(sec, nanosec)`` in body_frame, or the wheels' motor
        torques of it (and the rods' dipole) with that stamp."""
        if self.wheel_drive is not None:
            self.wheel_drive.answer(sec, nanosec, torque_body, self._publish_wheels)
            return
        assert self._publish_torque is not None
        frame = self.session.body_frame
        encode = self._encoders.get(frame)
        if encode is None:  # the header packed once per body_frame
            encode = self._encoders[frame] = stamped_floats_encoder(frame, 6)
            if len(self._encoders) > 16:
                self._encoders = {frame: encode}
        self._publish_torque(encode(sec, nanosec, _ZERO_FORCE + torque_body))

    def _publish_wheels(self, data: bytes) -> None:
        assert self.wheels_publisher is not None
        self.wheels_publisher.publish(data)

    def dipole(self, sec: int, nanosec: int, dipole_body: tuple[float, float, float]) -> None:
        """Publish the rods' ``dipole`` [A m²] stamped ``(sec, nanosec)`` in body_frame."""
        assert self.dipole_publisher is not None
        self.dipole_publisher.publish(encode_vector3_stamped(
            sec * 1_000_000_000 + nanosec, self.session.body_frame, dipole_body))

    def diagnostics(self, report: DiagnosticReport) -> None:
        """Publish one ``/diagnostics`` status, stamped with the node clock."""
        self.diagnostics_publisher.publish(report)

    def log(self, level: int, text: str) -> None:
        """A log line of the session."""
        logger = self.get_logger()
        (logger.warning if level == LEVEL_WARN else logger.info)(text)


def controller_usage() -> str:
    """``attitude_controller --help``: the parameters, from the one table."""
    rows = [ParameterRow(p.name, 'double array' if p.type is tuple else
                         {float: 'double', str: 'string'}[p.type], p.default, p.range_text(),
                         p.description, p.read_only) for p in CONTROLLER_PARAMETERS]
    return '\n'.join([
        'usage: attitude_controller [-h] [--ros-args -p NAME:=VALUE ... [-r FROM:=TO] ...]',
        '',
        'Quaternion-feedback PD attitude control: reads odom (or orientation and twist),',
        'publishes torque stamped like the tick it answers. See docs/closed-loop.md.',
        '',
        'options:',
        '  -h, --help  print this text and exit (ROS is not started)',
        '',
        'parameters (--ros-args -p NAME:=VALUE; run-time ones also with ros2 param set):',
        format_parameter_help(rows)])


@closed_pipe_safe
def main(args: list[str] | None = None) -> int:
    """Run the controller until SIGINT (exit 0); bad parameters: ``error: ...``, exit 2
    (:func:`~.serve.run_executable`)."""
    return run_executable(args, controller_usage, AttitudeControllerNode, _serve)


def _serve(node: Node) -> None:
    """The controller's inputs on the raw-take loop beside an executor for the rest (the
    fast path), else everything on rclpy's stock executor."""
    assert isinstance(node, AttitudeControllerNode)
    if fast_path_problem() is None:
        serve_beside_executor(node, node.loop())
    else:
        node.get_logger().info(SERVING_LINE)
        rclpy.spin(node)


if __name__ == '__main__':
    sys.exit(main())
