"""Hard cases 5 and 10 through the node: 10⁵ gyro messages with timing faults (docs/hard-cases.md).

A naive node integrates over whatever stamp difference arrives: a duplicate gives dt = 0, a
reordered or backward stamp a negative dt (the attitude runs backwards), a gap one huge step,
a looping bag a jump of minus its length; a NaN poisons the state for good; and a quaternion
renormalised from q or −q at random makes the published stream flip sign.

Here one in-process node (the shipped ``strapdown`` scene, real rclpy publishers and
subscriptions in a context of the test's own), served as the executable serves it (its
raw-take loop in a thread of its own, an executor for the rest), receives 10⁵
``angular_velocity`` messages with
random jitter, duplicates, swapped neighbours, short backward steps, gaps longer than
``max_dt``, backward jumps longer than ``time_jump_threshold`` and non-finite values, with
rates up to 40 rad/s so the attitude passes w = 0 thousands of times. Checked: nothing
crashes; every published orientation is finite, unit and on the side of the previous one
(q · q_prev ≥ 0, hard case 5); accepted plus rejected equals the messages sent, in the node's
counters and in its /diagnostics; and the published stream is bit-for-bit the core's
(:class:`GyroStream` + :class:`OutputTracker`) for the same messages.

The inputs are published as CDR bytes (:func:`encode_vector3_stamped`, byte-equal to rclpy's
serialisation: ``test/msgs/test_cdr.py``) and the orientations recorded as bytes, every queued
one per wake-up, then decoded with rclpy's own ``deserialize_message``: the harness's Python
messages and one executor wake-up per message would otherwise take most of the run.
"""

import math
import threading

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
import numpy as np
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from ros_helpers import DEEP_RELIABLE_QOS, Harness, unique_namespace

from rigid_body_attitude.msgs.cdr import encode_vector3_stamped
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.rclpy_internals import raw_taker
from rigid_body_attitude.session.outputs import OutputTracker
from rigid_body_attitude.core.propagator import build_propagator
from rigid_body_attitude.core.dynamics.scene import load_scene
from rigid_body_attitude.session.stream import GyroStream

MESSAGES = 100_000
BATCH = 2000  # published, then spun until the node has taken all of them (nothing dropped)
BASE_NS = 1_700_000_000 * 10**9 + 123_456_789
MS = 1_000_000
MAX_DT = 0.1
TIME_JUMP_THRESHOLD = 1.0


def faulty_stream(count, seed=10):
    """``count`` (stamp [ns], rate (x, y, z)) pairs with every kind of timing fault.

    Nominal 1 kHz with ±0.4 ms jitter; per message: 2 % duplicate stamp, 2 % swapped with the
    next, 0.3 % a short step back (0.2-0.9 s, under the jump threshold: stale until the
    clock catches up), 0.5 % a gap of 0.15-0.5 s (> max_dt), 0.1 % a jump back of 2-5 s
    (> threshold: reset), 0.2 % a NaN or ±Inf component. The rate changes every ~100
    messages to a random vector of up to 40 rad/s.
    """
    rng = np.random.default_rng(seed)
    clock = BASE_NS
    rate = (0.0, 0.0, 0.0)
    stamps, rates = [], []
    for k in range(count):
        draw = rng.random()
        if k % 100 == 0:
            rate = tuple((rng.uniform(-1.0, 1.0, 3) * rng.uniform(0.0, 40.0 / math.sqrt(3.0)))
                         .tolist())
        if draw < 0.02 and stamps:
            stamp = stamps[-1]                                      # duplicate
        else:
            clock += MS + int(rng.uniform(-0.4, 0.4) * MS)          # jitter
            if draw < 0.023:
                clock -= int(rng.uniform(0.2, 0.9) * 1e9)          # short step back
            elif draw < 0.028:
                clock += int(rng.uniform(0.15, 0.5) * 1e9)         # gap
            elif draw < 0.029:
                clock -= int(rng.uniform(2.0, 5.0) * 1e9)          # looping bag
            stamp = clock
        value = rate
        if 0.029 <= draw < 0.031:
            bad = list(rate)
            bad[int(rng.integers(3))] = [math.nan, math.inf, -math.inf][int(rng.integers(3))]
            value = tuple(bad)
        stamps.append(stamp)
        rates.append(value)
    for k in np.flatnonzero(rng.random(count - 1) < 0.02):         # swapped neighbours
        stamps[k], stamps[k + 1] = stamps[k + 1], stamps[k]
    return stamps, rates


def rate_message(stamp_ns, rate):
    """The CDR bytes of a Vector3Stamped body rate stamped ``stamp_ns``."""
    return encode_vector3_stamped(stamp_ns, 'base_link', rate)


def record_raw(harness, message_type, topic):
    """Record the CDR bytes of every message on ``topic``: each callback also takes every
    message queued behind its own (one executor wake-up for many messages)."""
    messages = []
    take = []
    subscription = harness.node.create_subscription(
        message_type, topic, lambda data: _take_all(data, messages, take[0]), DEEP_RELIABLE_QOS,
        raw=True)
    take.append(raw_taker(subscription, True))
    harness.subscriptions[topic] = subscription
    return messages


def _take_all(data, messages, take):
    """Append ``data`` and every message ``take`` still finds queued."""
    while data is not None:
        messages.append(data)
        data = take()


def core_outputs(stamps, rates):
    """What the stream rules publish for the same messages: attitudes (w, x, y, z), and the
    stream with its counts."""
    propagator = build_propagator(load_scene('strapdown'))
    stream = GyroStream(propagator, MAX_DT, TIME_JUMP_THRESHOLD)
    tracker = OutputTracker()
    published = []
    for stamp_ns, rate in zip(stamps, rates):
        if stream.add(stamp_ns, rate).moved:
            published.append(tracker.attitude(propagator))
    return np.array(published), stream


def test_a_hundred_thousand_faulty_gyro_messages(ros, request):
    namespace = unique_namespace(request)
    harness = Harness(ros, namespace)
    overrides = {'scene': 'strapdown', 'max_dt': MAX_DT,
                 'time_jump_threshold': TIME_JUMP_THRESHOLD}
    for topic, kind in {'angular_velocity': 'subscription', 'orientation': 'publisher'}.items():
        overrides[f'qos_overrides.{namespace}/{topic}.{kind}.reliability'] = 'reliable'
        overrides[f'qos_overrides.{namespace}/{topic}.{kind}.depth'] = 5000
    node = harness.add_node(AttitudePropagatorNode(
        context=ros.context, namespace=namespace,
        parameter_overrides=[Parameter(name, value=value) for name, value in overrides.items()]))
    publisher = harness.publisher(Vector3Stamped, 'angular_velocity')
    orientations = record_raw(harness, QuaternionStamped, 'orientation')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()

    stamps, rates = faulty_stream(MESSAGES)
    expected, core = core_outputs(stamps, rates)
    inputs = [rate_message(stamp_ns, rate) for stamp_ns, rate in zip(stamps, rates)]
    loop = node.serving_loop()
    thread = threading.Thread(target=loop.run, daemon=True)
    thread.start()
    try:
        for start in range(0, MESSAGES, BATCH):
            stop = min(start + BATCH, MESSAGES)
            for data in inputs[start:stop]:
                publisher.publish(data)
            assert harness.spin_until(lambda: node.built.session.received_count() >= stop,
                                      60.0), (
                f'the node took {node.built.session.received_count()} of {stop} messages')
        assert harness.spin_until(lambda: len(orientations) >= len(expected), 30.0)
        harness.spin_for(0.1)
        check_outputs(harness, node, (orientations, diagnostics), (expected, core))

        # Still alive and integrating after all that.
        last = max(stamps) + 20 * MS  # a jump ahead: taken when two more samples confirm it
        for k in range(3):
            publisher.publish(rate_message(last + k * MS, (0.0, 0.0, 1.0)))
        assert harness.spin_until(lambda: len(orientations) > len(expected), 5.0)
    finally:
        loop.stop()
        thread.join(5.0)
    assert not thread.is_alive()
    loop.close()


def check_outputs(harness, node, recorded, from_core):
    """What the node counted, reported and published against the core's run."""
    orientations, diagnostics = recorded
    expected, core = from_core

    # Every message is accounted for exactly once, in the node and in its diagnostics.
    assert node.built.session.received_count() == MESSAGES
    stream = node.built.session.stream
    rejected = stream.rejected
    assert stream.accepted + sum(rejected.values()) + len(stream.pending) == MESSAGES
    assert dict(rejected) == dict(core.rejected) and stream.accepted == core.accepted
    for reason in ('stale_stamp', 'gap', 'time_jump', 'non_finite'):
        assert rejected[reason] >= 50, (reason, dict(rejected))  # every fault was exercised

    def diagnostics_complete():
        for message in diagnostics:
            if message.status and message.status[0].name == node.get_fully_qualified_name():
                values = {pair.key: pair.value for pair in message.status[0].values}
                if int(values['received']) == MESSAGES:
                    assert int(values['accepted']) == stream.accepted
                    assert all(int(values[f'rejected {reason}']) == count
                               for reason, count in rejected.items())
                    return True
        return False
    assert harness.spin_until(diagnostics_complete, 5.0)

    # Outputs: finite, unit, never flipping sign, and the core's to the bit.
    published = np.array([(m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z)
                          for m in (deserialize_message(data, QuaternionStamped)
                                    for data in orientations)])
    assert published.shape == expected.shape
    assert np.all(np.isfinite(published))
    assert np.max(np.abs(np.linalg.norm(published, axis=1) - 1.0)) <= 1e-12
    assert np.all(np.sum(published[1:] * published[:-1], axis=1) >= 0.0)
    assert np.sum(published[:, 0] < 0.0) >= 1000  # the stream really crossed w = 0 a lot
    np.testing.assert_array_equal(published, expected)
