"""A PD attitude controller written as most rclpy users write one: a Node, one subscription
callback, one publisher, rclpy.spin on the stock executor.

It reads the plant's state from ``odom`` (nav_msgs/Odometry: the attitude in the pose, the
body rate in the twist) and answers every message with a ``torque`` (geometry_msgs/
WrenchStamped) stamped like it: the lockstep contract of docs/closed-loop.md. The law is the
package's (docs/closed-loop.md, "The law") toward the identity attitude, clipped to
``torque_limit``. Run it against ``propagation_node ... -p lockstep:=true``::

    python plain_controller.py --ros-args -p kp:=0.05 -p kd:=0.04 -p torque_limit:=0.02
"""

import rclpy
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


class PlainController(Node):
    """Answers each ``odom`` message with a ``torque`` of the same stamp."""

    def __init__(self):
        super().__init__('plain_controller')
        self.kp = self.declare_parameter('kp', 0.1).value
        self.kd = self.declare_parameter('kd', 0.04).value
        self.torque_limit = self.declare_parameter('torque_limit', 0.0).value
        self.publisher = self.create_publisher(WrenchStamped, 'torque', 10)
        self.subscription = self.create_subscription(
            Odometry, 'odom', self.odom_callback, 10)

    def odom_callback(self, odom):
        q = odom.pose.pose.orientation      # body -> world, the target is the identity
        rate = odom.twist.twist.angular     # body axes
        sign = 1.0 if q.w >= 0.0 else -1.0  # the shorter of the two rotations
        torque = [-self.kp * sign * error - self.kd * omega
                  for error, omega in ((q.x, rate.x), (q.y, rate.y), (q.z, rate.z))]
        if self.torque_limit > 0.0:
            torque = [max(-self.torque_limit, min(self.torque_limit, value))
                      for value in torque]
        command = WrenchStamped()
        command.header.stamp = odom.header.stamp        # answers this tick
        command.header.frame_id = odom.child_frame_id   # body_frame
        command.wrench.torque.x, command.wrench.torque.y, command.wrench.torque.z = torque
        self.publisher.publish(command)


def main(args=None):
    rclpy.init(args=args)
    node = PlainController()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
