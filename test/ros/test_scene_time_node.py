"""Scene time in the node: a dynamics node on ``use_sim_time`` whose clock starts at 1000.37 s
publishes the magnetometer samples of the core propagator from t = 0 (the orbit and the field
read scene time, 0 at the first tick), and commands stamped far from the clock, before and
after that first tick, are counted and change nothing."""

from __future__ import annotations

from typing import Any

from geometry_msgs.msg import TwistStamped, Vector3Stamped
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from ros_helpers import Harness, stamp, unique_namespace
from sensor_msgs.msg import MagneticField

from rigid_body_attitude.ros.node import AttitudePropagatorNode

from magnetic_loop import core_field_samples

SCENE = 'bdot_detumbling_commanded'
MS = 1_000_000
TICK_NS = 100 * MS
TICKS = 31


def nanoseconds(message: Any) -> int:
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def dipole_stamped(stamp_ns: int) -> Vector3Stamped:
    message = Vector3Stamped()
    message.header.stamp = stamp(stamp_ns)
    message.header.frame_id = 'base_link'
    message.vector.x = 0.2
    return message


def test_the_node_samples_the_field_at_scene_time_and_far_commands_change_nothing(ros,
                                                                                  request):
    harness = Harness(ros, unique_namespace(request))
    node = harness.add_node(AttitudePropagatorNode(
        context=ros.context, namespace=harness.node.get_namespace(),
        parameter_overrides=[Parameter('scene', value=SCENE),
                             Parameter('use_sim_time', value=True),
                             Parameter('publish_rate', value=10.0)]))
    harness.publisher(Clock, '/clock')
    harness.publisher(Vector3Stamped, 'dipole')
    twists = harness.record(TwistStamped, 'twist')
    fields = harness.record(MagneticField, 'imu/mag')
    harness.wait_for_connections()
    session = node.built.session

    def send(stamp_ns: int) -> None:
        expected = session.received_count() + 1
        harness.publishers['dipole'].publish(dipole_stamped(stamp_ns))
        assert harness.spin_until(lambda: session.received_count() >= expected, 5.0)

    # Before the first tick: a wall-clock stamp against a sim clock, the far past.
    send(1_700_000_000 * 10**9)
    send(1 * 10**9)
    assert session.rejection_counts()['not_started'] == 2
    first_ns = 1000 * 10**9 + 370 * MS
    for k in range(TICKS):
        if k == 10:  # after the start: the same two, now far from the clock
            send(1_700_000_000 * 10**9)
            send(1 * 10**9)
        clock = Clock()
        clock.clock = stamp(first_ns + k * TICK_NS)
        harness.publishers['/clock'].publish(clock)
        assert harness.spin_until(lambda: len(twists) >= k + 1, 5.0), (k, len(twists))
    assert [nanoseconds(t) for t in twists] == [first_ns + k * TICK_NS for k in range(TICKS)]
    assert harness.spin_until(lambda: len(fields) >= TICKS - 1, 5.0)
    counts = session.rejection_counts()
    assert (counts['not_started'], counts['future_stamp'], counts['stale_stamp']) == (2, 1, 1)
    assert session.commands_accepted == 0
    stamps = [nanoseconds(f) for f in fields]
    assert stamps == [first_ns + 30 * MS + k * TICK_NS for k in range(TICKS - 1)]
    measured = [(f.magnetic_field.x, f.magnetic_field.y, f.magnetic_field.z) for f in fields]
    assert measured == core_field_samples(SCENE, first_ns, TICK_NS, TICKS, stamps)
