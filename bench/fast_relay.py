"""Fast relay: the job of ``bench/relay.py`` done the fastest way rclpy 7.1 allows.

``imu`` (sensor_msgs/Imu) in, ``pose`` (geometry_msgs/PoseStamped, stamp = the gyro stamp) out,
plus optional extra outputs (``orientation`` as geometry_msgs/QuaternionStamped, ``imu_data``
as sensor_msgs/Imu with the orientation filled in) to price each extra publisher. No physics:
it is the yardstick of the middleware's own cost, and the node's gyro path works the same way.

The gyro subscription is ``raw=True`` and sits in a callback group no executor runs. The main
thread waits on it with one reused ``_rclpy.WaitSet`` and, per wake-up, takes *every* queued
message (``subscription.handle.take_message(Imu, True)`` until None), decodes the CDR bytes
with ``struct`` and publishes pre-laid-out CDR bytes (``publisher.publish(bytes)`` is public
API). A ``SingleThreadedExecutor`` in a daemon thread serves everything else the node has
(parameter services); it sleeps in ``rcl_wait`` and costs nothing per gyro message.

Usage: ``python bench/fast_relay.py [--outputs pose,orientation,imu_data]
[--best-effort-input] [--ros-args ...]``; ``bench/node_throughput.py`` measures it.
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


class FastRelay(Node):
    """The relay node: publishers, and the gyro subscription with its per-message callback.

    The callback is the one place a gyro message is handled, whichever loop takes it.
    """

    def __init__(self, outputs: List[str], best_effort_input: bool = False) -> None:
        """Create the outputs and the ``imu`` subscription (left to :func:`spin_draining`).

        The subscription is RELIABLE unless ``best_effort_input`` (which also accepts
        best-effort publishers, but lets the middleware drop samples it cannot deliver).
        """
        super().__init__('bench_fast_relay')
        self.omega_body = (0.0, 0.0, 0.0)
        self.outputs = RawOutputs(self, outputs)
        input_qos = reliable_qos()
        if best_effort_input:
            input_qos.reliability = ReliabilityPolicy.BEST_EFFORT
        self.imu_subscription = self.create_subscription(
            Imu, IMU_TOPIC, self.imu_raw_callback, input_qos, raw=True,
            callback_group=NeverExecuted())

    def imu_raw_callback(self, imu_cdr: bytes) -> None:
        """Decode the gyro rate from the CDR bytes and publish the outputs."""
        self.omega_body = imu_gyro(imu_cdr)
        self.outputs.publish(imu_cdr, _IDENTITY_XYZW)


def spin_draining(node: Node, subscription, callback: Callable) -> None:
    """Wait on ``subscription``; after each wake-up take and handle every queued message.

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
                taken = take(msg_type, raw)
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


def run(outputs: List[str], best_effort_input: bool) -> None:
    """Build the relay and serve it until shutdown."""
    node = FastRelay(outputs, best_effort_input)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    others = threading.Thread(target=serve_others, args=(executor,), daemon=True)
    try:
        others.start()  # everything but the gyro subscription (parameter services)
        spin_draining(node, node.imu_subscription, node.imu_subscription.callback)
    finally:
        executor.shutdown()
        if others.is_alive():
            others.join()
        node.destroy_node()


def main() -> int:
    """Parse ``--outputs`` and run the relay until SIGINT."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
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
        run(outputs, args.best_effort_input)
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
