"""Benchmark helper process: the node's non-gyro traffic at a fixed rate (default 100 Hz).

Run by ``bench/soak_mixed.py``; not meant for direct use. Per tick it publishes one
``set_pose`` (identity attitude, frame ``world``), sends one ``set_parameters`` request
(``max_dt`` and ``body_frame``, alternating between two valid values each) and one
``~/reset`` request to the node ``--node`` (default ``/attitude_propagator``). It never
waits for a reply inside a tick: replies are counted as they come.

Protocol (one JSON object per stdout line): ``{"event": "matched"}`` once the node's
``set_pose`` subscription and both services are there, ``{"event": "counts", ...}`` on
SIGINT/SIGTERM with the ticks, the replies received and the parameter sets the node
refused, then it exits.
"""

import argparse
import json
import signal
import sys
import time

from geometry_msgs.msg import PoseStamped
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions
from rcl_interfaces.srv import SetParameters
from std_srvs.srv import Trigger

_stop_requested = False


def _request_stop(signum, frame) -> None:
    global _stop_requested
    _stop_requested = True


class MixedTraffic:
    """set_pose, set_parameters and ~/reset from one timer; replies counted."""

    PARAMETER_VALUES = ((0.1, 'base_link'), (0.2, 'imu_link'))

    def __init__(self, node, target: str, rate: float) -> None:
        """Publisher and clients towards the node ``target``; a timer at ``rate`` Hz."""
        self.node = node
        self.pose_publisher = node.create_publisher(PoseStamped, 'set_pose', QoSProfile(depth=100))
        self.parameters_client = node.create_client(SetParameters, f'{target}/set_parameters')
        self.reset_client = node.create_client(Trigger, f'{target}/reset')
        self.counts = {'ticks': 0, 'set_pose': 0, 'parameter_replies': 0,
                       'parameters_refused': 0, 'reset_replies': 0, 'resets_failed': 0}
        self.pose = PoseStamped()
        self.pose.header.frame_id = 'world'
        self.pose.pose.orientation.w = 1.0
        self.rate = rate

    def ready(self) -> bool:
        """Whether the node's set_pose subscription and both services are there."""
        return (self.pose_publisher.get_subscription_count() > 0
                and self.parameters_client.service_is_ready()
                and self.reset_client.service_is_ready())

    def start(self) -> None:
        """Start the timer."""
        self.timer = self.node.create_timer(1.0 / self.rate, self.tick)

    def tick(self) -> None:
        """One set_pose, one parameter set, one reset."""
        self.counts['ticks'] += 1
        self.pose.header.stamp = self.node.get_clock().now().to_msg()
        self.pose_publisher.publish(self.pose)
        self.counts['set_pose'] += 1
        max_dt, body_frame = self.PARAMETER_VALUES[self.counts['ticks'] % 2]
        request = SetParameters.Request(parameters=[
            Parameter('max_dt', value=max_dt).to_parameter_msg(),
            Parameter('body_frame', value=body_frame).to_parameter_msg()])
        self.parameters_client.call_async(request).add_done_callback(self._parameters_done)
        self.reset_client.call_async(Trigger.Request()).add_done_callback(self._reset_done)

    def _parameters_done(self, future) -> None:
        self.counts['parameter_replies'] += 1
        results = future.result().results
        self.counts['parameters_refused'] += sum(not result.successful for result in results)

    def _reset_done(self, future) -> None:
        self.counts['reset_replies'] += 1
        self.counts['resets_failed'] += not future.result().success


def main() -> int:
    """Send the traffic until SIGINT/SIGTERM; print the counts."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rate', type=float, default=100.0, help='ticks per second')
    parser.add_argument('--node', default='/attitude_propagator', help='the node to talk to')
    parser.add_argument('--match-timeout', type=float, default=30.0)
    args, ros_args = parser.parse_known_args()
    signal.signal(signal.SIGTERM, _request_stop)
    signal.signal(signal.SIGINT, _request_stop)
    rclpy.init(args=[sys.argv[0]] + ros_args, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('bench_mixed_traffic')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    traffic = MixedTraffic(node, args.node, args.rate)
    try:
        deadline = time.monotonic() + args.match_timeout
        while not traffic.ready():
            if time.monotonic() > deadline or _stop_requested:
                print(json.dumps({'event': 'error', 'reason': 'node not found'}), flush=True)
                return 2
            executor.spin_once(timeout_sec=0.05)
        print(json.dumps({'event': 'matched'}), flush=True)
        traffic.start()
        while not _stop_requested:
            executor.spin_once(timeout_sec=0.1)
        print(json.dumps({'event': 'counts', **traffic.counts}), flush=True)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
