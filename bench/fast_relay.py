"""Prototype fast relay: the same job as ``bench/relay.py`` done the fastest ways rclpy allows.

``imu`` (sensor_msgs/Imu) in, ``pose`` (geometry_msgs/PoseStamped, stamp = the gyro stamp) out,
plus optional extra outputs (``orientation`` as geometry_msgs/QuaternionStamped and
``imu_data`` as sensor_msgs/Imu) to price each extra publisher. ``--mode`` picks the technique:

``waitset`` (default, the fastest)
    A hand-rolled loop over rclpy's own wait set (``_rclpy.WaitSet``, built once and reused):
    wait, then take *every* queued message with ``subscription.handle.take_message(type,
    raw=True)`` until it returns None, decode the CDR bytes with ``struct`` and publish
    pre-laid-out CDR bytes with ``publisher.publish(bytes)``. No executor, no Python message
    objects, one wait per burst instead of one per message.
``waitset-obj``
    The same loop taking and publishing Python message objects (isolates the serialization
    cost from the executor cost).
``ste-raw``
    ``SingleThreadedExecutor`` with a ``raw=True`` subscription and bytes publishing.
``ste-drain``
    ``SingleThreadedExecutor``; the callback handles its message and then drains the rest of
    the queue with ``take_message`` (public objects only, no private import).
``events`` / ``events-raw``
    ``rclpy.experimental.EventsExecutor`` (C++ executor, new in Jazzy 7.1) with message objects
    / raw bytes.

Usage: ``python bench/fast_relay.py [--mode M] [--outputs pose,orientation,imu_data]
[--ros-args ...]``. Findings and numbers: ``bench/NOTES.md``.
"""

import argparse
import struct
import sys
from typing import Callable, List

from _common import header_cdr, IMU_TOPIC, imu_gyro, POSE_TOPIC, reliable_qos
from geometry_msgs.msg import PoseStamped, QuaternionStamped
import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerGuardCondition
from sensor_msgs.msg import Imu

MODES = ('waitset', 'waitset-obj', 'ste-raw', 'ste-drain', 'events', 'events-raw')
OUTPUTS = ('pose', 'orientation', 'imu_data')

_QUATERNION = struct.Struct('<4d')

#: The last decoded gyro rate: the prototype decodes it like the node would, then drops it.
latest_omega_body = [(0.0, 0.0, 0.0)]


class RawOutputs:
    """Serialized outputs built from a serialized Imu: pose, orientation and imu_data.

    Each output is a preallocated ``bytearray`` laid out once (header with the ``world``
    frame, then the body); per message only the stamp and the orientation are rewritten.
    """

    def __init__(self, node: Node, outputs: List[str]) -> None:
        """Create one publisher per requested output."""
        self.publishers = []
        frame = header_cdr('world')
        self.body_start = len(frame)
        for name in outputs:
            if name == 'pose':
                publisher = node.create_publisher(PoseStamped, POSE_TOPIC, reliable_qos())
                buffer = bytearray(frame + struct.pack('<7d', 0, 0, 0, 0, 0, 0, 1))
                offset = self.body_start + 24  # after the position
            elif name == 'orientation':
                publisher = node.create_publisher(QuaternionStamped, 'orientation',
                                                  reliable_qos())
                buffer = bytearray(frame + _QUATERNION.pack(0, 0, 0, 1))
                offset = self.body_start
            else:
                publisher = node.create_publisher(Imu, 'imu_data', reliable_qos())
                buffer = None  # copied from the input message
                offset = 0
            self.publishers.append((publisher.handle.publish_raw, buffer, offset))

    def publish(self, imu_cdr: bytes, quaternion_xyzw) -> None:
        """Publish every output for one input message with the input's stamp."""
        stamp = imu_cdr[4:12]
        for publish_raw, buffer, offset in self.publishers:
            if buffer is None:
                copy = bytearray(imu_cdr)
                (length,) = struct.unpack_from('<I', imu_cdr, 12)
                start = 4 + ((12 + length + 7) // 8) * 8
                _QUATERNION.pack_into(copy, start, *quaternion_xyzw)
                publish_raw(bytes(copy))
            else:
                buffer[4:12] = stamp
                _QUATERNION.pack_into(buffer, offset, *quaternion_xyzw)
                publish_raw(bytes(buffer))


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
        """Publish every output for one input message with the input's stamp."""
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


def raw_handler(outputs: RawOutputs) -> Callable[[bytes], None]:
    """Return the per-message work on serialized bytes: decode the gyro, publish outputs."""
    def handle(imu_cdr: bytes) -> None:
        latest_omega_body[0] = imu_gyro(imu_cdr)
        outputs.publish(imu_cdr, (0.0, 0.0, 0.0, 1.0))
    return handle


def object_handler(outputs: ObjectOutputs) -> Callable[[Imu], None]:
    """Return the per-message work on an ``Imu`` object: read the gyro, publish outputs."""
    def handle(imu: Imu) -> None:
        omega = imu.angular_velocity
        latest_omega_body[0] = (omega.x, omega.y, omega.z)
        outputs.publish(imu, (0.0, 0.0, 0.0, 1.0))
    return handle


def spin_draining(node: Node, subscription, handle: Callable, raw: bool) -> None:
    """Wait on ``subscription``; after each wake-up take and handle every queued message.

    The wait set is built once (one subscription, the SIGINT guard condition) and reused;
    ``rcl_wait`` releases the GIL. Returns when the context shuts down (SIGINT).
    """
    context = node.context
    sigint_guard = SignalHandlerGuardCondition(context)
    take = subscription.handle.take_message
    msg_type = subscription.msg_type
    subscription_handle = subscription.handle
    wait_set = _rclpy.WaitSet(1, 1, 0, 0, 0, 0, context.handle)
    try:
        while context.ok():
            wait_set.clear_entities()
            wait_set.add_subscription(subscription_handle)
            wait_set.add_guard_condition(sigint_guard.handle)
            wait_set.wait(-1)
            taken = take(msg_type, raw)
            while taken is not None:
                handle(taken[0])
                taken = take(msg_type, raw)
    finally:
        sigint_guard.destroy()
        wait_set.destroy_when_not_in_use()


def run(mode: str, outputs: List[str]) -> None:
    """Build the relay node for ``mode`` and spin it until shutdown."""
    node = rclpy.create_node('bench_fast_relay')
    raw = mode in ('waitset', 'ste-raw', 'ste-drain', 'events-raw')
    handle = raw_handler(RawOutputs(node, outputs)) if raw else object_handler(
        ObjectOutputs(node, outputs))
    if mode.startswith('waitset'):
        subscription = node.create_subscription(Imu, IMU_TOPIC, handle, reliable_qos(),
                                                raw=raw)
        spin_draining(node, subscription, handle, raw)
        return
    if mode == 'ste-drain':
        subscription = None

        def drain(imu_cdr: bytes) -> None:
            handle(imu_cdr)
            taken = subscription.handle.take_message(Imu, True)
            while taken is not None:
                handle(taken[0])
                taken = subscription.handle.take_message(Imu, True)
        subscription = node.create_subscription(Imu, IMU_TOPIC, drain, reliable_qos(),
                                                raw=True)
    else:
        node.create_subscription(Imu, IMU_TOPIC, handle, reliable_qos(), raw=raw)
    if mode.startswith('events'):
        from rclpy.experimental import EventsExecutor
        executor = EventsExecutor()
    else:
        executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        if mode.startswith('events'):
            # EventsExecutor.spin() (and spin_once() without a timeout) busy-loops in rclpy
            # 7.1.6 on this machine, runs no callback and ignores SIGINT; a finite timeout
            # works (bench/NOTES.md).
            while rclpy.ok():
                executor.spin_once(timeout_sec=1.0)
        else:
            executor.spin()
    finally:
        executor.shutdown()


def main() -> int:
    """Parse ``--mode`` and ``--outputs`` and run the relay until SIGINT."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--mode', choices=MODES, default='waitset')
    parser.add_argument('--outputs', default='pose',
                        help=f'comma-separated subset of {",".join(OUTPUTS)}')
    args, ros_args = parser.parse_known_args()
    outputs = [name for name in args.outputs.split(',') if name]
    unknown = sorted(set(outputs) - set(OUTPUTS))
    if unknown:
        parser.error(f'unknown outputs {unknown}; expected a subset of {list(OUTPUTS)}')
    rclpy.init(args=[sys.argv[0]] + ros_args)
    try:
        run(args.mode, outputs)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
