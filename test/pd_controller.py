"""A minimal quaternion-feedback PD attitude controller node, for lockstep tests and benchmarks.

Run as a process: ``python pd_controller.py [--ros-args -r __ns:=/ns -p kp:=0.05 ...]``. It
subscribes to ``orientation`` (QuaternionStamped) and ``twist`` (TwistStamped) and, once both
of one stamp arrived, publishes on ``torque`` a WrenchStamped with that same stamp:

    tau = -kp * sign(q_w) * q_vec - kd * omega_body

(B. Wie, H. Weiss, A. Arapostathis, "Quaternion feedback regulator for spacecraft eigenaxis
rotations", J. Guidance 12(3), 1989, eq. 9 with the identity as the target), saturated per
axis at ``torque_limit`` [N m]. Every tick it receives is answered once, as the lockstep
contract asks (docs/closed-loop.md). With ``wait_for_subscribers`` N it subscribes to the
state only once ``torque`` has N matched subscribers (the node and a recorder), so a recorder
misses none of its commands.
"""

from __future__ import annotations

import sys

from geometry_msgs.msg import QuaternionStamped, TwistStamped, WrenchStamped
import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

QOS = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                 reliability=ReliabilityPolicy.RELIABLE)


class PdController(Node):
    """Answers each (orientation, twist) pair of one stamp with a torque of that stamp."""

    def __init__(self) -> None:
        super().__init__('pd_controller')
        self.kp = float(self.declare_parameter('kp', 0.05).value)
        self.kd = float(self.declare_parameter('kd', 0.04).value)
        self.limit = float(self.declare_parameter('torque_limit', 0.02).value)
        self.pending: dict[tuple[int, int], list[object | None]] = {}
        self.answered: set[tuple[int, int]] = set()
        self.publisher = self.create_publisher(WrenchStamped, 'torque', QOS)
        self.wait_for_subscribers = int(self.declare_parameter('wait_for_subscribers', 0).value)

    def subscribe(self) -> None:
        """Subscribe to the state (after :attr:`wait_for_subscribers` matched)."""
        self.create_subscription(QuaternionStamped, 'orientation',
                                 lambda m: self.take(m, 0), QOS)
        self.create_subscription(TwistStamped, 'twist', lambda m: self.take(m, 1), QOS)

    def take(self, message: QuaternionStamped | TwistStamped, slot: int) -> None:
        """Keep a message by stamp; answer once both of the stamp are there."""
        key = (message.header.stamp.sec, message.header.stamp.nanosec)
        if key in self.answered:
            return  # the node published this tick again (lockstep's first tick)
        pair = self.pending.setdefault(key, [None, None])
        pair[slot] = message
        if pair[0] is not None and pair[1] is not None:
            del self.pending[key]
            self.answered.add(key)
            self.answer(pair[0], pair[1])  # type: ignore[arg-type]

    def answer(self, orientation: QuaternionStamped, twist: TwistStamped) -> None:
        """Publish the PD torque stamped like the state it answers."""
        q = orientation.quaternion
        w = twist.twist.angular
        sign = 1.0 if q.w >= 0.0 else -1.0
        torque = [-self.kp * sign * qi - self.kd * wi
                  for qi, wi in ((q.x, w.x), (q.y, w.y), (q.z, w.z))]
        torque = [min(max(value, -self.limit), self.limit) for value in torque]
        message = WrenchStamped()
        message.header.stamp = orientation.header.stamp
        message.header.frame_id = twist.header.frame_id
        message.wrench.torque.x, message.wrench.torque.y, message.wrench.torque.z = torque
        self.publisher.publish(message)


def main() -> int:
    """Spin the controller until SIGINT."""
    rclpy.init(args=sys.argv)
    node = PdController()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while node.publisher.get_subscription_count() < node.wait_for_subscribers:
            executor.spin_once(timeout_sec=0.01)
        node.subscribe()
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
