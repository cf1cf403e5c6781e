"""Property tests of the checked decoders against rclpy's and ``rosbags``' typed deserialisers.

Every case goes through :func:`decoder_oracles.check` (the contract is stated there): a decoder
returns what rclpy's typed deserialiser returns or raises ``MalformedMessage``, and differs
from ``rosbags``' ``deserialize_cdr`` only by the documented choices. Inputs: truncations at
every length, bit flips, frame-id length fields, encapsulation ids, trailing bytes and random
bytes, on every decoder. Hypothesis runs derandomised (the same examples every run) with
bounded example counts.
"""

from __future__ import annotations

from collections import Counter
import struct

from decoder_oracles import check, encode, KINDS, same
from hypothesis import given, HealthCheck, settings, strategies as st
import pytest

from rigid_body_attitude.msgs import decoders
from rigid_body_attitude.msgs.errors import MalformedMessage

SETTINGS = settings(max_examples=150, derandomize=True, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
NAMES = sorted(KINDS)
STAMPED = [name for name in NAMES if name != 'float64']
FRAMES = [b'\x00', b'base_link\x00', b'imu\x00', b'abcdef\x00', 'ωξ'.encode() + b'\x00']


def _valid(name: str, little_endian: bool = True, frame: bytes = b'base_link\x00',
           alignment: int = 8, encapsulation: int | None = None) -> bytes:
    kind = KINDS[name]
    floats = [0.5 * (index + 1) for index in range(kind.floats)]
    return encode(little_endian, 1_700_000_000, 123_456_789, frame, floats, alignment,
                  encapsulation, header=name != 'float64')


@st.composite
def valid_messages(draw: st.DrawFn, stamped: bool = False) -> tuple[str, bytes]:
    """A decoder name and a well-formed message of its type (XCDR1 or XCDR2, either order)."""
    name = draw(st.sampled_from(STAMPED if stamped else NAMES))
    kind = KINDS[name]
    little_endian = draw(st.booleans())
    xcdr2 = draw(st.booleans())
    frame = draw(st.text(st.characters(blacklist_characters='\x00'), max_size=9))
    floats = draw(st.lists(st.floats(width=64), min_size=kind.floats, max_size=kind.floats))
    sec = draw(st.integers(-2 ** 31, 2 ** 31 - 1))
    nanosec = draw(st.integers(0, 2 ** 32 - 1))
    identifier = (0x0006 if xcdr2 else 0x0000) | int(little_endian)
    data = encode(little_endian, sec, nanosec, frame.encode() + b'\x00', floats,
                  4 if xcdr2 else 8, identifier, header=name != 'float64')
    return name, data


@pytest.mark.parametrize('name', NAMES)
@pytest.mark.parametrize('frame', FRAMES)
def test_every_truncation_is_refused_as_malformed(name, frame):
    for little_endian in (True, False):
        data = _valid(name, little_endian, frame)
        assert check(name, data, warm=data) == 'all take'
        for size in range(len(data)):
            assert check(name, data[:size], warm=data) == 'all refuse', size
            with pytest.raises(MalformedMessage, match='truncated|exceeds message'):
                KINDS[name].decode(data[:size])


@pytest.mark.parametrize('name', NAMES)
def test_encapsulation_ids_are_those_rclpy_takes(name):
    data = _valid(name)
    outcomes = Counter()
    for first in (0x00, 0x01, 0x80, 0xff):
        for second in range(256):
            identifier = first << 8 | second
            mutated = struct.pack('>H', identifier) + data[2:]
            outcome = check(name, mutated, warm=data)
            outcomes[outcome] += 1
            taken = outcome.startswith(('all take', 'taken'))
            # Big-endian ids read these little-endian bytes as other numbers: the frame length
            # then exceeds the message (refused), except in Float64, which has no header.
            assert taken == (identifier in decoders.ENCAPSULATIONS and (
                decoders.ENCAPSULATIONS[identifier].little_endian or name == 'float64')), hex(
                    identifier)
    other_ids = 8 if name == 'float64' else 4  # taken ids other than 0x0000 and 0x0001
    assert outcomes['taken: encapsulation rosbags refuses'] == other_ids


@pytest.mark.parametrize('name', NAMES)
def test_xcdr2_messages_read_as_rclpy_reads_them(name):
    for little_endian in (True, False):
        for frame in FRAMES:
            identifier = 0x0006 | int(little_endian)
            data = _valid(name, little_endian, frame, alignment=4, encapsulation=identifier)
            warm = _valid(name, True, frame)  # primes the one-call path with this frame id
            assert check(name, data, warm=warm).startswith(('all take', 'taken: encapsulation'))


@SETTINGS
@given(message=valid_messages(), data=st.data())
def test_bit_flips(message, data):
    name, raw = message
    flips = data.draw(st.lists(st.integers(0, 8 * len(raw) - 1), min_size=1, max_size=3))
    mutated = bytearray(raw)
    for bit in flips:
        mutated[bit // 8] ^= 1 << bit % 8
    check(name, bytes(mutated), warm=raw)


@SETTINGS
@given(message=valid_messages(stamped=True),
       length=st.one_of(st.integers(0, 64), st.integers(0, 2 ** 32 - 1),
                        st.sampled_from([2 ** 32 - 1, 2 ** 31, 2 ** 31 - 1, 2 ** 16])))
def test_frame_length_fields(message, length):
    name, raw = message
    order = '<' if raw[1] & 1 else '>'
    mutated = raw[:12] + struct.pack(order + 'I', length) + raw[16:]
    outcome = check(name, mutated, warm=raw)
    if length > len(raw):
        assert outcome == 'all refuse'


@SETTINGS
@given(message=valid_messages(), trailing=st.binary(max_size=40))
def test_trailing_bytes_are_taken_as_rclpy_takes_them(message, trailing):
    name, raw = message
    outcome = check(name, raw + trailing, warm=raw)
    assert outcome.startswith(('all take', 'taken')), outcome
    assert same(KINDS[name].decode(raw + trailing), KINDS[name].decode(raw))


@SETTINGS
@given(name=st.sampled_from(NAMES), raw=st.binary(max_size=400))
def test_random_bytes(name, raw):
    check(name, raw)


@SETTINGS
@given(message=valid_messages(), tail=st.binary(max_size=400), cut=st.integers(0, 40))
def test_valid_start_random_rest(message, tail, cut):
    name, raw = message
    check(name, raw[:cut] + tail, warm=raw)


@SETTINGS
@given(name=st.sampled_from(STAMPED), frame=st.binary(max_size=12),
       length_delta=st.integers(-2, 2))
def test_frame_bytes_of_any_content(name, frame, length_delta):
    kind = KINDS[name]
    data = encode(True, 5, 6, frame, [1.0] * kind.floats)
    length = max(0, len(frame) + length_delta)
    check(name, data[:12] + struct.pack('<I', length) + data[16:])


def test_the_documented_differences_occur():
    """Each documented difference is reached by a concrete message (so none is vacuous)."""
    good = _valid('vector3_stamped')
    assert check('vector3_stamped', good + b'\x01' * 8) == 'taken: trailing bytes rosbags refuses'
    assert check('vector3_stamped', b'\x00\x03' + good[2:]) == (
        'taken: encapsulation rosbags refuses')
    inner_nul = _valid('vector3_stamped', frame=b'ab\x00c\x00')
    assert check('vector3_stamped', inner_nul) == 'refused: inner NUL rosbags keeps'
    for frame in (b'', b'abc', b'\xff\xfe\x00'):
        assert check('vector3_stamped', _valid('vector3_stamped', frame=frame)) == (
            'refused: frame id rclpy forgives'), frame


def test_reasons_are_short_and_name_the_fault():
    imu = _valid('imu_rate')
    cases = {
        imu[:20]: 'truncated: 20 of 324 bytes',
        b'\x01\x05' + imu[2:]: 'bad encapsulation 0x0105',
        imu[:12] + b'\xff\xff\xff\xff' + imu[16:]: (
            'frame_id length 4294967295 exceeds message (324 bytes)'),
        imu[:12] + b'\x00\x00\x00\x00' + imu[16:]: 'frame_id length 0',
        _valid('imu_rate', frame=b'\xc3\x28\x00'): 'frame_id is not UTF-8 (byte 0)',
        b'': 'truncated: 0 of at least 316 bytes',
    }
    for data, reason in cases.items():
        with pytest.raises(MalformedMessage) as caught:
            decoders.decode_imu_rate(data)
        assert caught.value.reason.startswith(reason), caught.value.reason
        assert caught.value.msgtype == 'sensor_msgs/msg/Imu'
    with pytest.raises(MalformedMessage, match='expected bytes, got int'):
        decoders.decode_imu_rate(5)  # type: ignore[arg-type]


def test_all_three_paths_give_the_same_values():
    """Primed one-call path, the look-up path and the full check agree (frames alternate)."""
    messages = [_valid('imu_rate', frame=frame) for frame in FRAMES] * 3
    messages += [_valid('imu_rate', frame=b'imu\x00')] * 3
    messages += [memoryview(message) for message in messages[:5]]
    messages += [bytearray(message) for message in messages[:5]]
    for data in messages:
        first = decoders.decode_imu_rate(data)
        assert first == decoders.parse_stamped(bytes(data), 'imu', 37)[:3] + (
            decoders.parse_stamped(bytes(data), 'imu', 37).body[13:16],)


def _outcome(run):
    try:
        return True, run()
    except MalformedMessage as err:
        return False, err.reason


@SETTINGS
@given(message=valid_messages(stamped=True), data=st.data())
def test_header_and_body_offset_agree_with_the_full_check(message, data):
    """``decode_header`` and ``body_offset`` (fast paths, frame ids learned) = parse_stamped."""
    name, raw = message
    kind = KINDS[name]
    flips = data.draw(st.lists(st.integers(0, 8 * len(raw) - 1), max_size=2))
    cut = data.draw(st.integers(0, len(raw) + 4))
    mutated = bytearray(raw + b'\x00' * 4)[:cut]
    for bit in flips:
        if bit // 8 < len(mutated):
            mutated[bit // 8] ^= 1 << bit % 8
    mutated = bytes(mutated)
    for _ in range(2):  # the second time, any good frame id is known (fast paths)
        whole = _outcome(lambda: decoders.parse_stamped(mutated, kind.msgtype, kind.floats))
        header = _outcome(lambda: decoders.parse_stamped(mutated, kind.msgtype, 0))
        offset = _outcome(lambda: decoders.body_offset(mutated, kind.msgtype, kind.floats))
        assert _outcome(lambda: decoders.decode_header(mutated)) == (
            (True, header[1][:3]) if header[0] else (False, header[1]))
        assert offset == ((True, (whole[1].body_offset, whole[1].encapsulation.little_endian))
                          if whole[0] else (False, whole[1]))
