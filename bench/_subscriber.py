"""Benchmark helper process: receive ``pose`` and record (stamp, receive time) per message.

Run by ``bench/node_throughput.py``; not meant for direct use. The measuring end must be
faster than anything it measures, so it uses the fast technique of ``bench/fast_relay.py``:
a reused wait set, every queued message taken per wake-up as raw CDR bytes, the stamp read
with ``struct`` (no message objects). The receive time is the wall clock (``time.time_ns()``)
right after the take; the publisher stamps with the same clock, and the node under test
copies the gyro stamp into the pose, so ``receive - stamp`` is the end-to-end latency.

Prints ``{"event": "matched"}`` once a publisher of ``pose`` is matched. On SIGTERM or SIGINT
it writes ``--out``: two little-endian int64 arrays of equal length, the stamps then the
receive times (ns), and exits.
"""

import argparse
from array import array
import json
import signal
import sys
import time

from _common import POSE_TOPIC, reliable_qos, stamp_ns
from geometry_msgs.msg import PoseStamped
import rclpy
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.signals import SignalHandlerOptions

_stop_requested = False


def _request_stop(signum, frame) -> None:
    global _stop_requested
    _stop_requested = True


def _record(subscription, context, stamps: array, receive_times: array) -> None:
    """Take every pose until a stop is requested, appending stamps and receive times."""
    take = subscription.handle.take_message
    handle = subscription.handle
    wall_ns = time.time_ns
    wait_set = _rclpy.WaitSet(1, 0, 0, 0, 0, 0, context.handle)
    matched = False
    while not _stop_requested:
        wait_set.clear_entities()
        wait_set.add_subscription(handle)
        wait_set.wait(50_000_000)
        taken = take(PoseStamped, True)
        while taken is not None:
            receive_times.append(wall_ns())
            stamps.append(stamp_ns(taken[0]))
            taken = take(PoseStamped, True)
        if not matched and handle.get_publisher_count() > 0:
            matched = True
            print(json.dumps({'event': 'matched'}), flush=True)
    wait_set.destroy_when_not_in_use()


def main() -> int:
    """Record poses until SIGTERM/SIGINT, then write them to ``--out``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', required=True, help='file for the recorded arrays')
    args, ros_args = parser.parse_known_args()
    signal.signal(signal.SIGTERM, _request_stop)
    signal.signal(signal.SIGINT, _request_stop)
    rclpy.init(args=[sys.argv[0]] + ros_args, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('bench_pose_subscriber')
    subscription = node.create_subscription(PoseStamped, POSE_TOPIC, lambda message: None,
                                            reliable_qos(), raw=True)
    stamps, receive_times = array('q'), array('q')
    try:
        _record(subscription, node.context, stamps, receive_times)
    finally:
        with open(args.out, 'wb') as out:
            stamps.tofile(out)
            receive_times.tofile(out)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
