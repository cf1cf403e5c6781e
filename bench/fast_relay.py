"""Prototype fast relay: the job of ``bench/relay.py`` done the fastest ways rclpy 7.1 allows.

``imu`` (sensor_msgs/Imu) in, ``pose`` (geometry_msgs/PoseStamped, stamp = the gyro stamp) out,
plus optional extra outputs (``orientation`` as geometry_msgs/QuaternionStamped, ``imu_data``
as sensor_msgs/Imu with the orientation filled in) to price each extra publisher. ``--mode``
picks the technique:

``waitset`` (default, the recipe in ``bench/NOTES.md``)
    The gyro subscription is ``raw=True`` and sits in a callback group no executor runs. The
    main thread waits on it with one reused ``_rclpy.WaitSet`` and, per wake-up, takes *every*
    queued message (``subscription.handle.take_message(Imu, True)`` until None), decodes the
    CDR bytes with ``struct`` and publishes pre-laid-out CDR bytes (``publisher.publish(bytes)``
    is public API). A ``SingleThreadedExecutor`` in a daemon thread serves everything else the
    node has (parameter services, timers); it sleeps in ``rcl_wait`` and costs nothing per
    gyro message.
``waitset-one``
    The same loop taking one message per wake-up (isolates the gain of draining).
``waitset-obj``
    The same loop taking and publishing Python message objects (isolates the serialization
    cost from the executor cost).
``ste-raw``
    ``SingleThreadedExecutor`` with a ``raw=True`` subscription and bytes publishing.
``ste-drain``
    ``SingleThreadedExecutor``; the raw callback handles its message and then drains the rest of
    the queue with ``take_message`` (public API only).
``events`` / ``events-raw`` / ``events-drain``
    ``rclpy.experimental.EventsExecutor`` (C++ executor, new in 7.1) with message objects /
    raw bytes / raw bytes and the draining callback of ``ste-drain``, spun with
    ``spin_once(timeout_sec=1.0)`` (its ``spin()`` busy-loops here).

Usage: ``python bench/fast_relay.py [--mode M] [--outputs pose,orientation,imu_data]
[--best-effort-input] [--ros-args ...]``. Findings and numbers: ``bench/NOTES.md``.
"""

import argparse
import struct
import sys
import threading
from typing import Callable, List

from _common import header_cdr, IMU_TOPIC, imu_gyro, POSE_TOPIC, reliable_qos
from geometry_msgs.msg import PoseStamped, QuaternionStamped
import rclpy
from rclpy.callback_groups import CallbackGroup
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import ReliabilityPolicy
from rclpy.signals import SignalHandlerGuardCondition
from sensor_msgs.msg import Imu

MODES = ('waitset', 'waitset-one', 'waitset-obj', 'ste-raw', 'ste-drain', 'events',
         'events-raw', 'events-drain')
OUTPUTS = ('pose', 'orientation', 'imu_data')

_QUATERNION = struct.Struct('<4d')
_IDENTITY_XYZW = (0.0, 0.0, 0.0, 1.0)


class NeverExecuted(CallbackGroup):
    """A callback group no executor runs: keeps an entity out of every executor's wait set.

    ``Executor`` only waits on entities whose group ``can_execute`` them, so a subscription in
    this group is left entirely to the caller's own loop (:func:`spin_draining`).
    """

    def can_execute(self, entity) -> bool:
        """Never: the entity is served by a hand-written loop."""
        return False

    def beginning_execution(self, entity) -> bool:
        """Never: the entity is served by a hand-written loop."""
        return False

    def ending_execution(self, entity) -> None:
        """Nothing to release: execution never begins."""


class RawOutputs:
    """Serialized outputs built from a serialized Imu: pose, orientation and imu_data.

    Each output is a preallocated ``bytearray`` laid out once (header with the ``world``
    frame, then the body); per message only the stamp and the orientation are rewritten.
    """

    def __init__(self, node: Node, outputs: List[str]) -> None:
        """Create one publisher per requested output."""
        self.publishers = []
        frame = header_cdr('world')
        for name in outputs:
            if name == 'pose':
                publisher = node.create_publisher(PoseStamped, POSE_TOPIC, reliable_qos())
                buffer = bytearray(frame + struct.pack('<7d', 0, 0, 0, 0, 0, 0, 1))
                offset = len(frame) + 24  # after the position
            elif name == 'orientation':
                publisher = node.create_publisher(QuaternionStamped, 'orientation',
                                                  reliable_qos())
                buffer = bytearray(frame + _QUATERNION.pack(*_IDENTITY_XYZW))
                offset = len(frame)
            else:
                publisher = node.create_publisher(Imu, 'imu_data', reliable_qos())
                buffer, offset = None, 0  # a copy of the input message
            self.publishers.append((publisher.publish, buffer, offset))

    def publish(self, imu_cdr: bytes, quaternion_xyzw) -> None:
        """Publish every output for one input message, stamped with the input's stamp."""
        stamp = imu_cdr[4:12]
        for publish, buffer, offset in self.publishers:
            if buffer is None:
                copy = bytearray(imu_cdr)
                (length,) = struct.unpack_from('<I', imu_cdr, 12)
                _QUATERNION.pack_into(copy, 4 + ((12 + length + 7) // 8) * 8, *quaternion_xyzw)
                publish(bytes(copy))
            else:
                buffer[4:12] = stamp
                _QUATERNION.pack_into(buffer, offset, *quaternion_xyzw)
                publish(bytes(buffer))


class ObjectOutputs:
    """The same outputs built as Python message objects."""

    def __init__(self, node: Node, outputs: List[str]) -> None:
        """Create one publisher per requested output."""
        self.pose = self.orientation = self.imu_data = None
        if 'pose' in outputs:
            self.pose = node.create_publisher(PoseStamped, POSE_TOPIC, reliable_qos())
        if 'orientation' in outputs:
            self.orientation = node.create_publisher(QuaternionStamped, 'orientation',
                                                     reliable_qos())
        if 'imu_data' in outputs:
            self.imu_data = node.create_publisher(Imu, 'imu_data', reliable_qos())

    def publish(self, imu: Imu, quaternion_xyzw) -> None:
        """Publish every output for one input message, stamped with the input's stamp."""
        x, y, z, w = quaternion_xyzw
        if self.pose is not None:
            pose = PoseStamped()
            pose.header.stamp = imu.header.stamp
            pose.header.frame_id = 'world'
            q = pose.pose.orientation
            q.x, q.y, q.z, q.w = x, y, z, w
            self.pose.publish(pose)
        if self.orientation is not None:
            stamped = QuaternionStamped()
            stamped.header.stamp = imu.header.stamp
            stamped.header.frame_id = 'world'
            q = stamped.quaternion
            q.x, q.y, q.z, q.w = x, y, z, w
            self.orientation.publish(stamped)
        if self.imu_data is not None:
            q = imu.orientation
            q.x, q.y, q.z, q.w = x, y, z, w
            self.imu_data.publish(imu)


class FastRelay(Node):
    """The relay node: publishers, and the gyro subscription with its per-message callback.

    The callback is the one place a gyro message is handled, whichever loop takes it.
    """

    def __init__(self, outputs: List[str], raw: bool, own_loop: bool,
                 best_effort_input: bool = False) -> None:
        """Create the outputs and the ``imu`` subscription (left to our loop if ``own_loop``).

        The subscription is RELIABLE unless ``best_effort_input`` (which also accepts
        best-effort publishers, but lets the middleware drop samples it cannot deliver).
        """
        super().__init__('bench_fast_relay')
        self.omega_body = (0.0, 0.0, 0.0)
        if raw:
            self.outputs = RawOutputs(self, outputs)
            callback = self.imu_raw_callback
        else:
            self.outputs = ObjectOutputs(self, outputs)
            callback = self.imu_callback
        input_qos = reliable_qos()
        if best_effort_input:
            input_qos.reliability = ReliabilityPolicy.BEST_EFFORT
        self.imu_subscription = self.create_subscription(
            Imu, IMU_TOPIC, callback, input_qos, raw=raw,
            callback_group=NeverExecuted() if own_loop else None)

    def imu_raw_callback(self, imu_cdr: bytes) -> None:
        """Decode the gyro rate from the CDR bytes and publish the outputs."""
        self.omega_body = imu_gyro(imu_cdr)
        self.outputs.publish(imu_cdr, _IDENTITY_XYZW)

    def imu_callback(self, imu: Imu) -> None:
        """Read the gyro rate from the message object and publish the outputs."""
        omega = imu.angular_velocity
        self.omega_body = (omega.x, omega.y, omega.z)
        self.outputs.publish(imu, _IDENTITY_XYZW)

    def imu_drain_callback(self, imu_cdr: bytes) -> None:
        """Handle this message, then every other message already queued (``ste-drain``)."""
        take = self.imu_subscription.handle.take_message
        while imu_cdr is not None:
            self.imu_raw_callback(imu_cdr)
            taken = take(Imu, True)
            imu_cdr = taken[0] if taken is not None else None


def spin_draining(node: Node, subscription, callback: Callable, drain: bool = True) -> None:
    """Wait on ``subscription``; after each wake-up take and handle every queued message.

    With ``drain`` false only one message is taken per wake-up (for comparison).

    One wait set (the subscription, the SIGINT guard condition and a guard condition triggered
    on context shutdown) is built once and reused; ``rcl_wait`` releases the GIL. Returns when
    the context shuts down.
    """
    context = node.context
    sigint_guard = SignalHandlerGuardCondition(context)
    shutdown_guard = GuardCondition(None, None, context=context)
    context.on_shutdown(shutdown_guard.trigger)
    handle = subscription.handle
    take, msg_type, raw = handle.take_message, subscription.msg_type, subscription.raw
    wait_set = _rclpy.WaitSet(1, 2, 0, 0, 0, 0, context.handle)
    try:
        while context.ok():
            wait_set.clear_entities()
            wait_set.add_subscription(handle)
            wait_set.add_guard_condition(sigint_guard.handle)
            wait_set.add_guard_condition(shutdown_guard.handle)
            wait_set.wait(1_000_000_000)
            taken = take(msg_type, raw)
            while taken is not None:
                callback(taken[0])
                taken = take(msg_type, raw) if drain else None
    finally:
        wait_set.destroy_when_not_in_use()
        sigint_guard.destroy()
        shutdown_guard.destroy()


def serve_others(executor) -> None:
    """Spin ``executor`` until it or the context shuts down (body of the helper thread)."""
    try:
        executor.spin()
    except ExternalShutdownException:
        pass


def run(mode: str, outputs: List[str], best_effort_input: bool) -> None:
    """Build the relay for ``mode`` and spin it until shutdown."""
    raw = mode in ('waitset', 'waitset-one', 'ste-raw', 'ste-drain', 'events-raw',
                   'events-drain')
    own_loop = mode.startswith('waitset')
    node = FastRelay(outputs, raw, own_loop, best_effort_input)
    if mode in ('ste-drain', 'events-drain'):
        node.imu_subscription.callback = node.imu_drain_callback
    if mode.startswith('events'):
        from rclpy.experimental import EventsExecutor
        executor = EventsExecutor()
    else:
        executor = SingleThreadedExecutor()
    executor.add_node(node)
    others = threading.Thread(target=serve_others, args=(executor,), daemon=True)
    try:
        if own_loop:
            # Everything but the gyro subscription (parameter services, timers) is served here.
            others.start()
            spin_draining(node, node.imu_subscription, node.imu_subscription.callback,
                          drain=mode != 'waitset-one')
        elif mode.startswith('events'):
            # EventsExecutor.spin() (and spin_once() without a timeout) busy-loops in rclpy
            # 7.1.6 here, runs no callback and ignores SIGINT; a finite timeout works.
            while rclpy.ok():
                executor.spin_once(timeout_sec=1.0)
        else:
            executor.spin()
    finally:
        executor.shutdown()
        if others.is_alive():
            others.join()
        node.destroy_node()


def main() -> int:
    """Parse ``--mode`` and ``--outputs`` and run the relay until SIGINT."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--mode', choices=MODES, default='waitset')
    parser.add_argument('--outputs', default='pose',
                        help=f'comma-separated subset of {",".join(OUTPUTS)}')
    parser.add_argument('--best-effort-input', action='store_true',
                        help='subscribe to imu BEST_EFFORT instead of RELIABLE')
    args, ros_args = parser.parse_known_args()
    outputs = [name for name in args.outputs.split(',') if name]
    unknown = sorted(set(outputs) - set(OUTPUTS))
    if unknown:
        parser.error(f'unknown outputs {unknown}; expected a subset of {list(OUTPUTS)}')
    rclpy.init(args=[sys.argv[0]] + ros_args)
    try:
        run(args.mode, outputs, args.best_effort_input)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # SIGINT shuts the context down under a callback still publishing a backlog (RCLError,
        # "publisher's context is invalid") or under a take (RuntimeError "Unable to convert
        # call argument"); after shutdown neither is a failure.
        if rclpy.ok():
            raise
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
