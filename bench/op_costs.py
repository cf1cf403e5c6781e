"""Per-operation CPU cost of the pieces an rclpy gyro -> pose node is made of.

Measures, in one process, the thread CPU time (``time.thread_time_ns``: what the operation
itself burns, less sensitive to other load on the machine than wall time) of: building and
(de)serializing messages, hand-decoding CDR with ``struct``, taking a message (object vs raw),
publishing (object vs serialized bytes, with and without a matched subscriber in another
process), a wait-set wake-up, and one ``SingleThreadedExecutor`` / ``EventsExecutor``
dispatch of a ready message. Prints a Markdown table (median of ``--repeats`` batches).
First it checks the hand-written CDR helpers of ``_common.py`` against rclpy's serializer
(exit 1 on a mismatch), since the fast path relies on them.

Usage: ``python bench/op_costs.py [--repeats 5] [--batch 2000]``; findings in ``NOTES.md``.
"""

import argparse
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Callable, List, Tuple

from _common import (imu_cdr, imu_gyro, IMU_TOPIC, pose_cdr, POSE_TOPIC, reliable_qos,
                     ros_env, set_stamp_ns, stamp_ns)
from geometry_msgs.msg import PoseStamped, QuaternionStamped
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import Imu

BENCH = Path(__file__).resolve().parent


def check_cdr_helpers() -> None:
    """Check the hand-written CDR layouts against rclpy's serializer before timing them.

    For frame_ids of every length 0..17 (all paddings) the hand-built Imu and PoseStamped
    must deserialize to the intended fields and have the serializer's length, and the
    hand decoders must read back the serializer's stamp and gyro rate exactly.
    """
    omega_body = (0.125, -2.5e-3, 31.0)
    for length in range(18):
        frame_id = 'f' * length
        imu_buffer = imu_cdr(omega_body, frame_id)
        set_stamp_ns(imu_buffer, 1_700_000_000_123_456_789)
        imu = deserialize_message(bytes(imu_buffer), Imu)
        rate = imu.angular_velocity
        if (imu.header.frame_id != frame_id or (rate.x, rate.y, rate.z) != omega_body
                or imu.header.stamp.sec != 1_700_000_000
                or imu.header.stamp.nanosec != 123_456_789):
            raise SystemExit(f'error: hand-built Imu wrong for frame_id {frame_id!r}: {imu}')
        reserialized = serialize_message(imu)
        if (len(reserialized) != len(imu_buffer) or imu_gyro(reserialized) != omega_body
                or stamp_ns(reserialized) != 1_700_000_000_123_456_789):
            raise SystemExit(f'error: hand decoding wrong for frame_id {frame_id!r}')
        pose = deserialize_message(bytes(pose_cdr(frame_id)), PoseStamped)
        if pose.header.frame_id != frame_id or pose.pose.orientation.w != 1.0:
            raise SystemExit(f'error: hand-built PoseStamped wrong for {frame_id!r}: {pose}')


def cost_us(operation: Callable[[], object], batch: int, repeats: int) -> float:
    """Return the median over ``repeats`` of the mean thread CPU µs of ``operation``."""
    samples = []
    for _ in range(repeats):
        start = time.thread_time_ns()
        for _ in range(batch):
            operation()
        samples.append((time.thread_time_ns() - start) / batch / 1e3)
    return statistics.median(samples)


def message_costs(batch: int, repeats: int) -> List[Tuple[str, float]]:
    """Costs of building, (de)serializing and hand-decoding messages (no middleware)."""
    imu_bytes = bytes(imu_cdr((0.1, -0.2, 0.3)))
    pose_buffer = pose_cdr('world')

    def build_pose() -> PoseStamped:
        pose = PoseStamped()
        pose.header.frame_id = 'world'
        pose.pose.orientation.w = 1.0
        return pose
    pose = build_pose()

    def hand_pose() -> bytes:
        pose_buffer[4:12] = imu_bytes[4:12]
        return bytes(pose_buffer)
    return [
        ('build Imu()', cost_us(Imu, batch, repeats)),
        ('build + fill PoseStamped', cost_us(build_pose, batch, repeats)),
        ('serialize_message(PoseStamped)', cost_us(lambda: serialize_message(pose), batch,
                                                   repeats)),
        ('deserialize_message(Imu bytes)', cost_us(lambda: deserialize_message(imu_bytes, Imu),
                                                   batch, repeats)),
        ('struct: Imu stamp + gyro from bytes', cost_us(
            lambda: (stamp_ns(imu_bytes), imu_gyro(imu_bytes)), batch, repeats)),
        ('struct: PoseStamped bytes from stamp', cost_us(hand_pose, batch, repeats)),
    ]


def publish_costs(node, batch: int, repeats: int, matched: bool) -> List[Tuple[str, float]]:
    """Costs of one publish call (object vs bytes) for pose, orientation and imu_data."""
    suffix = ' (matched reader)' if matched else ' (no reader)'
    pose_publisher = node.create_publisher(PoseStamped, POSE_TOPIC, reliable_qos())
    if matched:
        deadline = time.monotonic() + 20.0
        while pose_publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.5)
    pose = PoseStamped()
    pose.pose.orientation.w = 1.0
    pose_bytes = bytes(pose_cdr('world'))
    rows = [('publish(PoseStamped)' + suffix,
             cost_us(lambda: pose_publisher.publish(pose), batch, repeats)),
            ('publish(bytes) PoseStamped' + suffix,
             cost_us(lambda: pose_publisher.publish(pose_bytes), batch, repeats)),
            ('handle.publish_raw(bytes) PoseStamped' + suffix,
             cost_us(lambda: pose_publisher.handle.publish_raw(pose_bytes), batch, repeats))]
    if not matched:
        orientation = node.create_publisher(QuaternionStamped, 'orientation', reliable_qos())
        imu_data = node.create_publisher(Imu, 'imu_data', reliable_qos())
        quaternion_bytes = bytes(pose_cdr('world')[:-24])  # header + 4 doubles
        imu_bytes = bytes(imu_cdr((0.1, -0.2, 0.3)))
        rows += [('publish(bytes) QuaternionStamped' + suffix,
                  cost_us(lambda: orientation.publish(quaternion_bytes), batch, repeats)),
                 ('publish(bytes) Imu' + suffix,
                  cost_us(lambda: imu_data.publish(imu_bytes), batch, repeats))]
    node.destroy_publisher(pose_publisher)
    return rows


def take_costs(node, batch: int, repeats: int) -> List[Tuple[str, float]]:
    """Costs of taking a queued Imu (object vs raw), of an empty take, and of a wake-up."""
    publisher = node.create_publisher(Imu, IMU_TOPIC, reliable_qos(batch + 10))
    raw_subscription = node.create_subscription(Imu, IMU_TOPIC, lambda message: None,
                                                reliable_qos(batch + 10), raw=True)
    object_subscription = node.create_subscription(Imu, IMU_TOPIC, lambda message: None,
                                                   reliable_qos(batch + 10))
    message = imu_cdr((0.1, -0.2, 0.3))
    wait_set = _rclpy.WaitSet(1, 0, 0, 0, 0, 0, node.context.handle)

    def fill() -> None:
        for index in range(batch):
            set_stamp_ns(message, index + 1)
            publisher.publish(bytes(message))
        time.sleep(0.2)

    def timed_takes(subscription) -> float:
        take = subscription.handle.take_message
        samples = []
        for _ in range(repeats):
            fill()
            start = time.thread_time_ns()
            taken = sum(take(Imu, subscription.raw) is not None for _ in range(batch))
            samples.append((time.thread_time_ns() - start) / max(taken, 1) / 1e3)
            while take(Imu, subscription.raw) is not None:
                pass
        return statistics.median(samples)

    def ready_wait() -> None:
        wait_set.clear_entities()
        wait_set.add_subscription(raw_subscription.handle)
        wait_set.wait(0)
    rows = [('take_message(Imu) object', timed_takes(object_subscription)),
            ('take_message(Imu, raw=True)', timed_takes(raw_subscription))]
    set_stamp_ns(message, 1)
    publisher.publish(bytes(message))
    time.sleep(0.2)
    rows.append(('wait-set wake-up (clear, add, rcl_wait on a ready subscription)',
                 cost_us(ready_wait, batch, repeats)))
    while raw_subscription.handle.take_message(Imu, True) is not None:
        pass
    rows.append(('take_message on an empty queue (returns None)', cost_us(
        lambda: raw_subscription.handle.take_message(Imu, True), batch, repeats)))
    for entity in (raw_subscription, object_subscription):
        node.destroy_subscription(entity)
    node.destroy_publisher(publisher)
    return rows


def executor_costs(node, batch: int, repeats: int) -> List[Tuple[str, float]]:
    """CPU per dispatched message of ``spin_once`` while messages are queued."""
    publisher = node.create_publisher(Imu, IMU_TOPIC, reliable_qos())
    message = bytes(imu_cdr((0.1, -0.2, 0.3)))
    dispatched = [0]

    def count(raw: bytes) -> None:
        dispatched[0] += 1
    subscription = node.create_subscription(Imu, IMU_TOPIC, count, reliable_qos(), raw=True)
    rows = []
    from rclpy.experimental import EventsExecutor
    for label, executor in (('SingleThreadedExecutor', SingleThreadedExecutor()),
                            ('EventsExecutor', EventsExecutor())):
        executor.add_node(node)
        samples = []
        for _ in range(repeats):
            for _ in range(batch // 4):
                publisher.publish(message)
            time.sleep(0.2)
            dispatched[0], calls = 0, 0
            start = time.thread_time_ns()
            while dispatched[0] < batch // 4 and calls < batch:
                executor.spin_once(timeout_sec=0.05)
                calls += 1
            samples.append((time.thread_time_ns() - start) / max(dispatched[0], 1) / 1e3)
        executor.remove_node(node)
        executor.shutdown()
        rows.append((f'{label}.spin_once per dispatched raw message (incl. its take)',
                     statistics.median(samples)))
    node.destroy_subscription(subscription)
    node.destroy_publisher(publisher)
    return rows


def main() -> int:
    """Measure every operation and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--repeats', type=int, default=5)
    parser.add_argument('--batch', type=int, default=2000)
    args = parser.parse_args()
    os.environ.update(ros_env(int(os.environ.get('ROS_DOMAIN_ID', '64'))))
    check_cdr_helpers()
    rclpy.init()
    node = rclpy.create_node('bench_op_costs')
    rows = message_costs(args.batch, args.repeats)
    rows += publish_costs(node, args.batch, args.repeats, matched=False)
    rows += take_costs(node, args.batch, args.repeats)
    rows += executor_costs(node, args.batch, args.repeats)
    with tempfile.TemporaryDirectory() as tmp:
        subscriber = subprocess.Popen(
            [sys.executable, str(BENCH / '_subscriber.py'), '--out', f'{tmp}/poses.bin'],
            env=dict(os.environ), stdout=subprocess.DEVNULL)
        try:
            rows += publish_costs(node, args.batch, args.repeats, matched=True)
        finally:
            subscriber.terminate()
            subscriber.wait(10)
    node.destroy_node()
    rclpy.try_shutdown()
    print('| operation | thread CPU (µs) |\n|---|---:|')
    for label, microseconds in rows:
        print(f'| {label} | {microseconds:.1f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
