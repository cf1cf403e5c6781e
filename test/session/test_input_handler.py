"""The input handler shared by the node and the replay tool, without ROS: it decodes, hands the
values (and an Imu's own bytes) to the session, and counts what it cannot use."""

import pytest
from conftest import BASE_NS, MS

from rigid_body_attitude.msgs import (
    TWIST_STAMPED, encode_imu, encode_twist_stamped, encode_vector3_stamped)
from rigid_body_attitude.session.decoding import input_handler

RATE = (0.0, 0.0, 2.0)


def test_imu_bytes_reach_the_sink_with_their_attitude(open_scene):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    messages = [encode_imu(BASE_NS + k * MS, 'imu_link', RATE) for k in range(3)]
    for data in messages:
        handle(data)
    # Each attitude (the first sample's too: the initial one) carries its own message.
    assert len(sink.attitudes) == 3 and sink.imus == messages


def test_vector3_input_has_no_imu_bytes(open_scene):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'angular_velocity')
    for k in range(3):
        handle(encode_vector3_stamped(BASE_NS + k * MS, 'imu_link', RATE))
    assert len(sink.attitudes) == 3 and sink.imus == [None, None, None]


def test_another_rate_type_feeds_the_topic_of_the_node(open_scene):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'angular_velocity', TWIST_STAMPED)
    for k in range(3):
        handle(encode_twist_stamped(BASE_NS + k * MS, 'imu_link', (9.0, 9.0, 9.0), RATE))
    handle(b'\x00\x01\x00\x00')
    assert len(sink.attitudes) == 3 and sink.imus == [None, None, None]
    assert session.malformed_by_topic == {'angular_velocity': 1}


class SinkFailure(Exception):
    """An adapter's own error raised by its sink."""


def test_a_failure_inside_the_session_is_counted_unless_the_adapter_reraises_it(open_scene):
    session, sink = open_scene('strapdown')

    def failing(sec, nanosec, attitude, imu):
        raise SinkFailure('from the sink')
    sink.attitude = failing
    messages = [encode_imu(BASE_NS + k * MS, 'imu_link', RATE) for k in range(3)]
    counted = input_handler(session, 'imu')
    for data in messages[:2]:
        counted(data)
    assert session.rejection_counts()['internal_error'] == 2
    with pytest.raises(SinkFailure):
        input_handler(session, 'imu', reraise=(SinkFailure,))(messages[2])
    assert session.rejection_counts()['internal_error'] == 2
