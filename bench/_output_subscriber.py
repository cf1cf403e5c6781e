"""Benchmark helper process: subscribe to every output of the node and count the messages.

Run by ``bench/node_dynamics_cpu.py``; not meant for direct use. Subscribes (raw CDR bytes,
reliable, keep last 100) to every topic of ``--topics`` (relative names, the node's
``OUTPUT_TOPICS``; ``/diagnostics`` absolute) with the types given as ``name=pkg/msg/Type``,
served by a reused wait set (no executor: the measuring end must cost little). Prints
``{"event": "matched", ...}`` once every subscription has a publisher, and on SIGINT/SIGTERM
``{"event": "counts", "counts": {topic: messages}}``.
"""

import argparse
import importlib
import json
import signal
import sys

import rclpy
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

_stop_requested = False


def _request_stop(signum, frame) -> None:
    global _stop_requested
    _stop_requested = True


def message_type(name: str):
    """``pkg/msg/Type`` → the message class."""
    package, _, type_name = name.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), type_name)


def main() -> int:
    """Count messages on every topic until SIGINT/SIGTERM."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--topics', required=True,
                        help='comma-separated topic=pkg/msg/Type')
    args, ros_args = parser.parse_known_args()
    signal.signal(signal.SIGTERM, _request_stop)
    signal.signal(signal.SIGINT, _request_stop)
    rclpy.init(args=[sys.argv[0]] + ros_args, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('bench_output_subscriber')
    qos = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE)
    subscriptions = {}
    for spec in args.topics.split(','):
        topic, _, type_name = spec.partition('=')
        subscriptions[topic] = (node.create_subscription(
            message_type(type_name), topic, lambda message: None, qos, raw=True),
            message_type(type_name))
    counts = {topic: 0 for topic in subscriptions}
    wait_set = _rclpy.WaitSet(len(subscriptions), 0, 0, 0, 0, 0, node.context.handle)
    matched = False
    try:
        while not _stop_requested:
            wait_set.clear_entities()
            for subscription, _ in subscriptions.values():
                wait_set.add_subscription(subscription.handle)
            wait_set.wait(100_000_000)
            for topic, (subscription, kind) in subscriptions.items():
                while subscription.handle.take_message(kind, True) is not None:
                    counts[topic] += 1
            if not matched and all(subscription.get_publisher_count() > 0
                                   for subscription, _ in subscriptions.values()):
                matched = True
                print(json.dumps({'event': 'matched'}), flush=True)
        print(json.dumps({'event': 'counts', 'counts': counts}), flush=True)
    finally:
        wait_set.destroy_when_not_in_use()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
