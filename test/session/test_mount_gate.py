"""The mount gate and the table of static transforms against hostile ``/tf_static`` traffic
and foreign frames, in milliseconds (no ROS traffic: the gate and the session of the node).

Invalid transforms are refused and counted per reason; a table flooded by thousands of
transforms still takes a later valid mount and never drops the mount in use; a sample in a
frame without a mount never holds up the samples of the frame with one; the frames awaiting a
mount and the samples held are bounded; untrusted strings reach the log only as a short,
escaped prefix.
"""

from __future__ import annotations

import math

from conftest import BASE_NS, MS
from rigid_body_attitude.msgs import encode_imu, encode_vector3_stamped
from rigid_body_attitude.msgs.tf_message import Transform
from rigid_body_attitude.msgs.untrusted import QUOTED_CHARACTERS, quoted
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.session.mount import MAX_TRANSFORMS, StaticTransforms
from rigid_body_attitude.session.mount_gate import HELD_SAMPLES, MountGate, PENDING_FRAMES

RATE = (0.3, -0.2, 1.1)
IDENTITY = (1.0, 0.0, 0.0, 0.0)
YAW_90 = (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))


def transform(parent: str, child: str, rotation=IDENTITY, translation=(0.0, 0.0, 0.0)):
    return Transform(0, 0, parent, child, translation, rotation)


def gated(open_scene, clocks, **parameters):
    """A strapdown session (no levelling), its sink, gate and gated gyro handler."""
    session, sink = open_scene('strapdown', align_seconds=0.0, **parameters)
    gate = MountGate(session, 5.0, lambda: clocks.monotonic)
    return session, sink, gate, gate.gated(input_handler(session, 'imu'))


def add(gate: MountGate, *transforms: Transform) -> None:
    """What the node does with a /tf_static message."""
    gate.count_refused(gate.add_transforms(transforms))
    gate.retry()


def test_a_foreign_frame_never_holds_up_the_mounted_stream(open_scene, clocks):
    """One sample in ``other_imu`` (no mount) before 1000 in ``imu_link`` (mounted on
    /tf_static): all 1000 integrated, the other counted ``foreign_frame``; a later sample in
    another frame is refused too (one IMU per topic)."""
    session, sink, gate, sample = gated(open_scene, clocks)
    add(gate, transform('base_link', 'imu_link', YAW_90))
    sample(encode_imu(BASE_NS - MS, 'other_imu', RATE))
    for k in range(1000):
        sample(encode_imu(BASE_NS + k * MS, 'imu_link', RATE))
    sample(encode_imu(BASE_NS + 1000 * MS, 'camera_imu', RATE))
    assert session.imu_frame == 'imu_link'
    assert session.accepted_count() == 1000 and len(sink.attitudes) == 1000
    assert session.rejection_counts()['foreign_frame'] == 2
    assert session.received_count() == 1002
    warnings = [text for _, text in sink.logs if 'foreign' in text or 'not the IMU' in text]
    assert warnings and "'other_imu'" in warnings[0] and "'imu_link'" in warnings[0]


def test_one_imu_per_topic_a_frame_needing_no_mount_on_the_other_topic(open_scene, clocks):
    """The IMU's frame ``base_link`` named on ``imu``: on ``angular_velocity`` samples in an
    empty frame are taken until one comes in ``base_link``, then only those; on ``imu`` an
    empty frame is foreign at once, and so is a frame without a mount on either topic."""
    session, _, gate, sample = gated(open_scene, clocks)
    rates = input_handler(session, 'angular_velocity')
    sample(encode_imu(BASE_NS, 'base_link', RATE))
    rates(encode_vector3_stamped(BASE_NS + MS, '', RATE))
    rates(encode_vector3_stamped(BASE_NS + 2 * MS, 'other_imu', RATE))
    sample(encode_imu(BASE_NS + 3 * MS, '', RATE))
    assert session.accepted_count() == 2
    assert session.rejection_counts()['foreign_frame'] == 2
    rates(encode_vector3_stamped(BASE_NS + 4 * MS, 'base_link', RATE))
    rates(encode_vector3_stamped(BASE_NS + 5 * MS, '', RATE))
    assert session.accepted_count() == 3
    assert session.rejection_counts()['foreign_frame'] == 3


def test_samples_held_until_the_mount_arrives_only_their_frame_integrated(open_scene, clocks):
    """The mount arrives after 300 samples of ``imu_link`` interleaved with 300 of other
    frames: the gate opens at once, the 300 held ``imu_link`` samples are integrated in order,
    the others counted ``foreign_frame``."""
    session, sink, gate, sample = gated(open_scene, clocks)
    for k in range(300):
        sample(encode_imu(BASE_NS + k * MS, 'imu_link', RATE))
        sample(encode_imu(BASE_NS + k * MS, f'other_{k % 3}', RATE))
    assert sink.attitudes == [] and not gate.open
    add(gate, transform('base_link', 'torso', YAW_90), transform('torso', 'imu_link'))
    assert gate.open and len(sink.attitudes) == 300  # at once, not at the next sample
    sample(encode_imu(BASE_NS + 300 * MS, 'imu_link', RATE))
    assert session.accepted_count() == 301 and len(sink.attitudes) == 301
    assert session.rejection_counts()['foreign_frame'] == 300
    assert session.rejection_counts()['no_mount'] == 0


def test_invalid_transforms_are_refused_and_counted_per_reason(open_scene, clocks):
    """Zero, near-zero, NaN, Inf and far-from-unit rotations, non-finite translations, empty,
    equal and overlong frames: each refused and counted under its reason, warned once per
    reason, never stored; a valid mount afterwards is found."""
    session, sink, gate, sample = gated(open_scene, clocks)
    add(gate,
        transform('base_link', 'imu_link', (0.0, 0.0, 0.0, 0.0)),
        transform('base_link', 'imu_link', (1e-8, 0.0, 0.0, 0.0)),
        transform('base_link', 'imu_link', (1e200, 0.0, 0.0, 0.0)),
        transform('base_link', 'imu_link', (0.9, 0.0, 0.0, 0.0)),
        transform('base_link', 'imu_link', (math.nan, 0.0, 0.0, 1.0)),
        transform('base_link', 'imu_link', (math.inf, 0.0, 0.0, 0.0)),
        transform('base_link', 'imu_link', IDENTITY, (0.0, math.inf, 0.0)),
        transform('base_link', 'imu_link', IDENTITY, (math.nan, 0.0, 0.0)),
        transform('', 'imu_link'), transform('imu_link', 'imu_link'),
        transform('base_link', 'x' * 4_000_000))
    counts = session.rejection_counts()
    assert (counts['tf_denormalized'], counts['tf_non_finite'], counts['tf_bad_frames']) == (
        4, 4, 3)
    assert gate.transforms.count == 0
    warned = [text for _, text in sink.logs if 'transforms refused' in text]
    assert len(warned) == 3 and max(len(text) for text in warned) < 600
    assert session.received_count() == 0  # transforms are not gyro inputs
    sample(encode_imu(BASE_NS, 'imu_link', RATE))
    assert not gate.open
    add(gate, transform('base_link', 'imu_link', YAW_90))
    sample(encode_imu(BASE_NS + MS, 'imu_link', RATE))
    assert gate.open and session.accepted_count() == 2


def test_a_flooded_table_takes_a_later_mount_and_keeps_the_one_in_use():
    """Three messages of 10 000 junk transforms, then the mount: the table stays at
    MAX_TRANSFORMS (the oldest dropped, counted ``tf_evicted``) and the mount is found; once
    protected (in use), 30 000 more junk transforms never drop it."""
    table = StaticTransforms()
    evicted = 0
    for batch in range(3):
        evicted += table.add_all(
            transform(f'junk_{batch}_{k}', f'leaf_{batch}_{k}') for k in range(10_000)
        )['tf_evicted']
    assert table.count == MAX_TRANSFORMS and evicted == 20_000
    assert table.add_all([transform('base_link', 'torso', YAW_90),
                          transform('torso', 'imu_link')])['tf_evicted'] == 2
    assert table.rotation('base_link', 'imu_link') == table.resolved('base_link')['imu_link'][0]
    table.protect('base_link', 'imu_link')
    for batch in range(3, 6):
        table.add_all(transform(f'junk_{batch}_{k}', f'leaf_{batch}_{k}')
                      for k in range(10_000))
    assert table.count == MAX_TRANSFORMS
    found = table.rotation('base_link', 'imu_link')
    assert found is not None and abs(found[0] - YAW_90[0]) < 1e-15


def test_frames_awaiting_a_mount_and_held_samples_are_bounded(open_scene, clocks):
    """20 000 samples, each in a new frame: at most PENDING_FRAMES frames tracked and
    HELD_SAMPLES samples held, every one dropped counted ``no_mount``; then the mounted
    frame's first sample opens the gate at once."""
    session, sink, gate, sample = gated(open_scene, clocks)
    add(gate, transform('base_link', 'imu_link'))
    for k in range(20_000):
        sample(encode_imu(BASE_NS + k * MS, f'junk_{k}', RATE))
    assert len(gate._deadlines) <= PENDING_FRAMES and len(gate._held) <= HELD_SAMPLES
    assert len(gate._held) + session.rejection_counts()['no_mount'] == 20_000
    sample(encode_imu(BASE_NS + 20_000 * MS, 'imu_link', RATE))
    assert gate.open and session.accepted_count() == 1
    assert session.rejection_counts()['foreign_frame'] + session.rejection_counts()[
        'no_mount'] == 20_000


def test_a_4mb_frame_id_reaches_the_log_as_a_short_escaped_prefix(open_scene, clocks):
    """Frames of 4 MB (control characters and an escape sequence in them) while waiting for a
    mount and after: every log line is short and holds no control character."""
    session, sink, gate, sample = gated(open_scene, clocks)
    huge = '\x1b[2J' + 'x' * (4 * 2**20) + '\n'
    for k in range(3):
        clocks.monotonic += 10.0  # past every throttle
        sample(encode_imu(BASE_NS + k * MS, huge, RATE))
    add(gate, transform('base_link', 'imu_link'))
    sample(encode_imu(BASE_NS + 3 * MS, 'imu_link', RATE))
    clocks.monotonic += 10.0
    sample(encode_imu(BASE_NS + 4 * MS, huge, RATE))
    assert session.rejection_counts()['no_mount'] == 3
    assert session.rejection_counts()['foreign_frame'] == 1
    assert len(sink.logs) >= 3
    for _, text in sink.logs:
        assert len(text) < 600 and '\x1b' not in text and '\n' not in text
    assert quoted(huge).startswith(repr(huge[:QUOTED_CHARACTERS]))
    assert quoted('imu_link') == "'imu_link'"


def test_held_samples_of_both_gyro_topics_go_back_to_their_own_handlers(open_scene, clocks):
    """Imu samples on ``imu`` and Vector3Stamped samples on ``angular_velocity`` held
    together until the mount arrives: each goes back to its own topic's handler (none
    decoded as the other type, so none counted malformed), all integrated in order."""
    session, sink, gate, imu = gated(open_scene, clocks)
    rates = gate.gated(input_handler(session, 'angular_velocity'))
    for k in range(100):
        imu(encode_imu(BASE_NS + 2 * k * MS, 'imu_link', RATE))
        rates(encode_vector3_stamped(BASE_NS + (2 * k + 1) * MS, 'imu_link', RATE))
    assert sink.attitudes == [] and not gate.open
    add(gate, transform('base_link', 'imu_link', YAW_90))
    assert gate.open
    assert session.rejection_counts()['malformed'] == 0
    assert session.accepted_count() == 200 and len(sink.attitudes) == 200
    assert [imu_bytes is not None for imu_bytes in sink.imus] == [True, False] * 100
