"""Per-sample cost of ``publish_tf``: the node's output path with and without ``/tf``, one run.

A ``RosOutputs`` of a real node (rclpy, Fast DDS set up as the node sets it up: the package's
profile, asynchronous publication) publishes
``orientation`` and ``pose`` per gyro sample stamped 1 ms apart (1 kHz), with a subscriber of
each output, ``/tf`` included, in another process (``ros2``-free: a ``python -c`` rclpy
node), so every publish really goes out. Contenders, over the same ``--samples`` samples
(garbage collector off, ``--repeats`` repetitions, minimum and median):

* ``no tf``: ``publish_tf`` false (one ``is None`` check per sample);
* ``tf 100 Hz``: ``tf_rate`` 100, a transform every 10th sample;
* ``tf every``: ``tf_rate`` 0, a transform per sample.

Usage: ``python bench/tf_output_cost.py [--samples 5000] [--repeats 5]``. Prints a Markdown
table with each cost per sample and as a ratio to ``no tf`` of the same run.
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import subprocess
import sys
import time

import rclpy
from rclpy.context import Context
from rclpy.node import Node

from rigid_body_attitude.ros.middleware import (
    use_asynchronous_publication, use_packaged_fastdds_profile)
from rigid_body_attitude.ros.outputs import RosOutputs

SUBSCRIBER = '''
import sys, rclpy
from rclpy.node import Node
from geometry_msgs.msg import PoseStamped, QuaternionStamped
from tf2_msgs.msg import TFMessage
from rigid_body_attitude.ros.qos import OUTPUT_QOS, TF_QOS
rclpy.init()
node = Node('tf_cost_subscriber')
subs = [node.create_subscription(PoseStamped, '/bench/pose', lambda m: None, OUTPUT_QOS),
        node.create_subscription(QuaternionStamped, '/bench/orientation', lambda m: None,
                                 OUTPUT_QOS),
        node.create_subscription(TFMessage, '/tf', lambda m: None, TF_QOS)]
print('ready', flush=True)
rclpy.spin(node)
'''


def _run(outputs: RosOutputs, samples: int) -> float:
    """Seconds per sample of ``outputs.attitude`` over ``samples`` 1 kHz stamps."""
    attitude = (0.9, 0.1, 0.2, 0.37)
    base_sec = 1_700_000_000
    gc.disable()
    start = time.perf_counter()
    for k in range(samples):
        outputs.attitude(base_sec + k // 1000, (k % 1000) * 1_000_000, attitude, None)
    elapsed = time.perf_counter() - start
    gc.enable()
    return elapsed / samples


def main() -> int:
    """Measure and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, default=5000)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args()
    use_packaged_fastdds_profile()
    use_asynchronous_publication()
    subscriber = subprocess.Popen([sys.executable, '-c', SUBSCRIBER], stdout=subprocess.PIPE,
                                  text=True, env=os.environ.copy())
    try:
        assert subscriber.stdout is not None and subscriber.stdout.readline().strip() == 'ready'
        context = Context()
        rclpy.init(context=context)
        node = Node('tf_cost', namespace='/bench', context=context)
        contenders = {}
        for name, rate in (('no tf', None), ('tf 100 Hz', 100.0), ('tf every', 0.0)):
            outputs = RosOutputs(node, gyro_scene=True)
            outputs.set_frames('world', 'base_link')
            if rate is not None:
                outputs.enable_tf(rate)
            contenders[name] = outputs
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not all(
                o.pose_raw.subscription_count() and o.orientation_raw.subscription_count()
                and (o.tf_raw is None or o.tf_raw.subscription_count())
                for o in contenders.values()):
            time.sleep(0.05)
        times: dict[str, list[float]] = {name: [] for name in contenders}
        for _ in range(args.repeats):
            for name, outputs in contenders.items():
                outputs._tf_due_ns = outputs._tf_last_ns = 0
                times[name].append(_run(outputs, args.samples))
        base = min(times['no tf'])
        print('| contender | min [µs/sample] | median [µs/sample] | min / no tf |')
        print('| --- | --- | --- | --- |')
        for name, values in times.items():
            print(f'| {name} | {min(values) * 1e6:.2f} | {statistics.median(values) * 1e6:.2f} '
                  f'| {min(values) / base:.2f} |')
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    finally:
        subscriber.kill()
        subscriber.wait()
    return 0


if __name__ == '__main__':
    sys.exit(main())
