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
  a :class:`~.raw_take_loop.RawTakeLoop` (every queued message per wake-up).
* Dynamics scenes advance on a timer of the node clock (``use_sim_time`` works) at
  ``publish_rate``, served by the same raw-take loop (timers only); commands arrive on
  ``torque`` (WrenchStamped) and ``rotor_torque`` (Vector3Stamped) when the scene takes them.
  ``~/reset`` restores the scene's initial state. A scene with ``sensors`` also publishes its
  simulated IMU, magnetometer and star tracker (``sensor_msgs/msg/Imu``,
  ``sensor_msgs/msg/MagneticField``, ``geometry_msgs/msg/PoseWithCovarianceStamped``:
  :mod:`rigid_body_attitude.session.sensors`) and the sensors' mounts on ``/tf_static``.
  With ``publish_clock`` or ``lockstep`` the scene is its own clock instead: a
  :class:`~.step_loop.StepLoop` makes the ticks on sim time (``/clock``,
  ``real_time_factor``, lockstep; docs/closed-loop.md).
* Commands (``set_pose``, ``set_pose_with_covariance``, ``torque``, ``rotor_torque``) are
  coalesced: only the newest of each topic matters, so each callback takes every message queued
  behind its own and hands the newest to the session once (the others counted ``superseded``). Log
  lines go through a queue with a thread of its own (:mod:`~.log_queue`), never written while the
  state lock is held.
* Gyro scenes read the sensor's mount from ``/tf_static`` when the samples' frame is not
  ``body_frame`` and ``mount_rpy`` is not set (:mod:`rigid_body_attitude.session.mount_gate`);
  with ``publish_tf`` the attitude also goes to ``/tf``.

Parameters are declared from :data:`rigid_body_attitude.session.parameters.PARAMETERS`; the
parameters, topics and callbacks are :class:`~.propagator_base.PropagatorMixin`'s, shared with
the managed node (:mod:`~.managed_node`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rigid_body_attitude.ros.raw_take_loop import RawTakeLoop
from rigid_body_attitude.ros.propagator_base import (
    LOG_EVERY_PERIODS, NodeParts, PropagatorMixin)
from rigid_body_attitude.ros.step_loop import step_loop
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.interface import NODE_INTERFACE
from rigid_body_attitude.session.settings import NODE_NAME

__all__ = ['AttitudePropagatorNode', 'LOG_EVERY_PERIODS']


class AttitudePropagatorNode(PropagatorMixin):
    """Feeds decoded messages to the scene's session and publishes what it produces.

    Keyword arguments go to :class:`rclpy.node.Node` (``context``, ``namespace``,
    ``parameter_overrides``, ``cli_args``, ...), so tests and tools can build the node
    in-process. Bad parameters or a bad scene raise :class:`InputError` or
    :class:`~rigid_body_attitude.core.errors.SceneError` from here. Every callback that touches
    the session holds :attr:`state_lock`, so the raw-take loop of :func:`~.serve.main` and the
    executor thread serving the rest never interleave.
    """

    def __init__(self, **node_options: Any) -> None:
        """Declare the parameters, load the scene, create the session, topics and timers."""
        super().__init__(NODE_NAME, **node_options)
        self.build(self.declare_parameters_of_table())
        self.add_on_set_parameters_callback(self.parameters_callback)
        self.add_post_set_parameters_callback(self.parameters_set_callback)

    def serving_loop(self) -> RawTakeLoop:
        """A :class:`RawTakeLoop` serving the gyro subscriptions (gyro scenes) and the timers (in
        the loop group); creating it takes them away from every executor. On the scene's own
        sim clock a :class:`StepLoop`, which also serves the commands."""
        parts = self.built
        timers = [timer for timer in (parts.output_timer, parts.diagnostics_timer)
                  if timer is not None]
        if parts.sim_clock is not None and isinstance(parts.session, DynamicsSession):
            return step_loop(self.context, parts.session, parts.sim_clock,
                             _served(parts, ('command',)), timers, parts.clock_output,
                             parts.state_lock, parts.outputs)
        return RawTakeLoop(self.context, _served(parts, ('sensor',)), timers)

    def destroy_node(self) -> None:
        """Write the queued log lines (at most 1 s), then destroy the node."""
        if self.parts is not None:
            self.parts.outputs.log_queue.stop()
        super().destroy_node()  # type: ignore[no-untyped-call]


def _served(parts: NodeParts, roles: tuple[str, ...]
            ) -> list[tuple[Any, Callable[[bytes], object]]]:
    """(subscription, handler) of the inputs of ``roles``."""
    return [(parts.subscriptions_by_topic[endpoint.name], parts.handlers[endpoint.name])
            for endpoint in NODE_INTERFACE.inputs(parts.situation, roles)]
