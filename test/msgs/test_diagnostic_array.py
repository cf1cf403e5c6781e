"""The DiagnosticArray encoder of rigid_body_attitude.msgs against rosbags' serialiser."""

import pytest

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.core.errors import InputError


def rosbags_bytes(stamp_ns, frame_id, statuses):
    """The same message serialised by ``rosbags``."""
    types = bag.typestore().types
    sec, nanosec = divmod(stamp_ns, 10**9)
    header = types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame_id)
    status = [types['diagnostic_msgs/msg/DiagnosticStatus'](
        level=s.level, name=s.name, message=s.message, hardware_id=s.hardware_id,
        values=[types['diagnostic_msgs/msg/KeyValue'](key=str(k), value=str(v))
                for k, v in s.values.items()]) for s in statuses]
    return bytes(bag.typestore().serialize_cdr(
        types[msgs.DIAGNOSTIC_ARRAY](header=header, status=status), msgs.DIAGNOSTIC_ARRAY))


# String lengths 0..4 and multi-byte UTF-8 put every field at each offset modulo 4.
STATUSES = [
    [],
    [msgs.DiagnosticStatus(0, '', '')],
    [msgs.DiagnosticStatus(1, '/attitude_propagator', 'stale input', 'imu0',
                           {'dropped': '3', 'gap_s': '0.25'})],
    [msgs.DiagnosticStatus(2, 'a', 'bc', 'def', {'': 'x', 'ü': 'ñéé'}),
     msgs.DiagnosticStatus(3, 'abcd', 'ünïcode', '', {'k': ''}),
     msgs.DiagnosticStatus(0, 'xyz', '', 'ab')],
]


@pytest.mark.parametrize('frame_id', ['', 'a', 'base_link'])
@pytest.mark.parametrize('statuses', STATUSES)
def test_encoder_byte_equal_to_rosbags_serializer(frame_id, statuses):
    stamp_ns = 1_700_000_123_456_789_012
    assert (msgs.encode_diagnostic_array(stamp_ns, frame_id, statuses)
            == rosbags_bytes(stamp_ns, frame_id, statuses))


def test_values_are_written_through_str_in_order():
    status = msgs.DiagnosticStatus(0, 'n', 'm', values={'b': 2, 'a': 1.5})
    message = bag.deserialize(msgs.encode_diagnostic_array(5, '', [status]),
                              msgs.DIAGNOSTIC_ARRAY)
    assert [(v.key, v.value) for v in message.status[0].values] == [('b', '2'), ('a', '1.5')]
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (0, 5)


@pytest.mark.parametrize('stamp_ns, statuses, match', [
    (2**31 * 10**9, [], '`stamp_ns`'),
    (1.5, [], '`stamp_ns`'),
    (0, [msgs.DiagnosticStatus(4, 'n', 'm')], '`level`'),
    (0, [msgs.DiagnosticStatus(0, None, 'm')], '`name`'),
])
def test_bad_arguments_are_input_errors(stamp_ns, statuses, match):
    with pytest.raises(InputError, match=match):
        msgs.encode_diagnostic_array(stamp_ns, '', statuses)
