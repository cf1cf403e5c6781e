"""What a typed rclpy subscription takes, sent as raw bytes by a real rclpy publisher.

For every input type of the node, a raw publisher sends well-formed, malformed and ambiguous
payloads (trailing bytes, each encapsulation kind, frame-id faults, truncations) to a typed
subscription and to a raw one on the same topic. The raw subscription receives every payload
byte for byte; the typed one receives, in order, exactly the messages
``rclpy.serialization.deserialize_message`` takes, with the same values (so that function is a
faithful oracle of a typed subscription); and every payload satisfies the decoder contract of
``decoder_oracles.check`` (taken by the decoder ⇒ taken by rclpy with the same values). In
particular a message with 100 bytes after its body reaches the typed subscription unchanged.
"""

from __future__ import annotations

from collections.abc import Iterator
import struct

from decoder_oracles import check, encode, KINDS, same
import pytest
from rclpy.serialization import deserialize_message
from ros_helpers import DEEP_RELIABLE_QOS, Harness, ros_session, RosContext, unique_namespace

#: One decoder per node input type (each checks its message's whole layout).
NAMES = ['imu', 'vector3_stamped', 'wrench_stamped', 'pose_stamped', 'twist_stamped',
         'quaternion_stamped']
SENTINEL_SEC = 9999


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    """A context and executor of the test's own."""
    with ros_session(ros_domain_id) as session:
        yield session


def _payloads(name: str) -> list[bytes]:
    count = KINDS[name].floats
    floats = [0.25 * (index + 1) for index in range(count)]

    def message(sec: int, frame: bytes = b'base_link\x00', little_endian: bool = True,
                alignment: int = 8, encapsulation: int | None = None) -> bytes:
        return encode(little_endian, sec, 7, frame, floats, alignment, encapsulation)
    good = message(1)
    payloads = [good, good + b'\x01', good + b'\xff' * 4, good + b'\xab' * 100,
                message(2, little_endian=False)]
    for identifier in (0x0003, 0x0009, 0x000b, 0x0002):
        payloads.append(message(identifier, little_endian=bool(identifier & 1),
                                alignment=4 if identifier >= 6 else 8,
                                encapsulation=identifier))
    payloads += [message(5, b'abcde\x00', alignment=4, encapsulation=0x0007),
                 message(6, b'abcde\x00', alignment=8, encapsulation=0x0007),  # misaligned
                 b'\x00\x04' + good[2:], b'\x01\x05' + good[2:],
                 message(7, b''), message(8, b'abc'), message(9, b'a\x00b\x00'),
                 message(10, b'\xff\xfe\x00'), message(11, 'ωξ'.encode() + b'\x00'),
                 good[:12] + struct.pack('<I', 2 ** 32 - 1) + good[16:],
                 good[:20], good[:len(good) - 1], good[:4]]
    return payloads


@pytest.mark.parametrize('name', NAMES)
def test_typed_subscription_takes_what_deserialize_message_takes(ros, request, name):
    kind = KINDS[name]
    harness = Harness(ros, unique_namespace(request))
    topic = f'in_{name}'
    typed = harness.record(kind.rclpy_class, topic)
    raw: list[bytes] = []
    harness.subscriptions[topic + '_raw'] = harness.node.create_subscription(
        kind.rclpy_class, topic, raw.append, DEEP_RELIABLE_QOS, raw=True)
    publisher = harness.publisher(kind.rclpy_class, topic)
    harness.wait_for_connections()
    assert harness.spin_until(lambda: publisher.get_subscription_count() == 2)
    payloads = _payloads(name)
    sentinel = encode(True, SENTINEL_SEC, 0, b'end\x00', [0.0] * kind.floats)
    for payload in payloads + [sentinel]:
        publisher.publish(payload)
    assert harness.spin_until(lambda: len(raw) == len(payloads) + 1 and any(
        message.header.stamp.sec == SENTINEL_SEC for message in typed), timeout=20.0), (
            len(raw), len(typed))
    assert raw[:-1] == payloads
    expected = []
    outcomes = set()
    for payload in payloads:
        outcomes.add(check(name, payload))
        try:
            expected.append(kind.values(deserialize_message(payload, kind.rclpy_class)))
        except Exception:  # rclpy's _rclpy.RMWError: the typed subscription drops it
            pass
    delivered = [kind.values(message) for message in typed[:-1]]
    assert len(delivered) == len(expected) and all(map(same, delivered, expected)), (
        delivered, expected)
    assert {'all take', 'taken: trailing bytes rosbags refuses',
            'taken: encapsulation rosbags refuses', 'refused: frame id rclpy forgives',
            'refused: inner NUL rosbags keeps', 'all refuse'} <= outcomes
    hundred_bytes_after = payloads[3]
    assert same(kind.decode(hundred_bytes_after), kind.decode(payloads[0]))
    assert same(delivered[3], delivered[0])
