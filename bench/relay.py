"""Bare rclpy relay, the throughput anchor: ``imu`` (sensor_msgs/Imu) -> ``pose`` (PoseStamped).

The plainest node a user would write: one subscription, one publisher, a callback that copies
the header into a ``PoseStamped`` and publishes it, spun by a ``SingleThreadedExecutor``.
Nothing else. ``bench/node_throughput.py`` measures it in the same run as the node, so the
node's figures can be read against what rclpy itself costs on this machine.

Usage: ``python bench/relay.py [--ros-args ...]``
"""

import sys

from _common import IMU_TOPIC, POSE_TOPIC, reliable_qos
from geometry_msgs.msg import PoseStamped
import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import Imu


class Relay(Node):
    """Republish each ``Imu`` header as a ``PoseStamped`` with the identity pose."""

    def __init__(self) -> None:
        """Create the subscription and the publisher (RELIABLE, deep queue)."""
        super().__init__('bench_relay')
        self.pose_publisher = self.create_publisher(PoseStamped, POSE_TOPIC, reliable_qos())
        self.imu_subscription = self.create_subscription(
            Imu, IMU_TOPIC, self.imu_callback, reliable_qos())

    def imu_callback(self, imu: Imu) -> None:
        """Publish a pose stamped with the gyro message's stamp."""
        pose = PoseStamped()
        pose.header = imu.header
        pose.pose.orientation.w = 1.0
        self.pose_publisher.publish(pose)


def main(args=None) -> int:
    """Spin the relay until SIGINT."""
    rclpy.init(args=args)
    relay = Relay()
    executor = SingleThreadedExecutor()
    executor.add_node(relay)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # SIGINT shuts the context down under a callback still publishing a backlog (RCLError,
        # "publisher's context is invalid") or under a take (RuntimeError "Unable to convert
        # call argument"); after shutdown neither is a failure.
        if rclpy.ok():
            raise
    finally:
        executor.shutdown()
        relay.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
