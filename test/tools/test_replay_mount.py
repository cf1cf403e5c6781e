"""The replay's mount from a bag's ``/tf_static``, as the node reads it from the topic.

Real rosbag2 files: Imu samples in the sensor frame ``imu_link`` (the body rates rotated into
it) and static transforms recorded on ``/tf_static`` (``tf2_msgs/msg/TFMessage``). The body's
attitude must come out as from the body rates themselves, ``imu/data`` must carry the sensor
frame's orientation; a bag without the transform drops every sample (``no_mount``) with one
note naming both frames.
"""

from __future__ import annotations

from pathlib import Path

from geometry_msgs.msg import TransformStamped
import numpy as np
import pytest
from rclpy.serialization import serialize_message
from scipy.spatial.transform import Rotation
from tf2_msgs.msg import TFMessage

from bag_fixtures import write_records
from rigid_body_attitude.bag import BagReader, deserialize
from rigid_body_attitude.msgs import IMU, TF_MESSAGE, encode_imu
from rigid_body_attitude.tools.replay import ReplayOptions, main, replay_bag

START_NS = 10_000_000_000
PERIOD_NS = 1_000_000
COUNT = 400
OMEGA_BODY = np.array([0.4, -1.1, 2.3])
#: base_link -> torso (yaw 90°), torso -> imu_link (roll 60°): imu_link in base_link.
YAW = Rotation.from_euler('z', 90.0, degrees=True)
ROLL = Rotation.from_euler('x', 60.0, degrees=True)
OPTIONS = dict(scene='strapdown', align_seconds=0.0, outputs=('orientation', 'imu/data'))


def static_transforms(*chain: tuple[str, str, Rotation]) -> bytes:
    """A TFMessage of (parent, child, rotation) as rclpy serialises it."""
    message = TFMessage()
    for parent, child, rotation in chain:
        transform = TransformStamped()
        transform.header.frame_id, transform.child_frame_id = parent, child
        r = transform.transform.rotation
        r.x, r.y, r.z, r.w = rotation.as_quat().tolist()
        message.transforms.append(transform)
    return bytes(serialize_message(message))


def write_mounted_bag(path: Path, frame: str, q_body_sensor: Rotation,
                      tf_static: list[bytes]) -> None:
    """Imu samples of the body rate OMEGA_BODY measured in ``frame`` mounted by
    ``q_body_sensor``, the ``tf_static`` records first (as a recorder started with the robot
    stores them)."""
    rate_sensor = tuple(q_body_sensor.inv().apply(OMEGA_BODY).tolist())
    records = [('/tf_static', START_NS - 1000, data) for data in tf_static]
    records += [('imu', START_NS + k * PERIOD_NS,
                 encode_imu(START_NS + k * PERIOD_NS, frame, rate_sensor))
                for k in range(COUNT)]
    write_records(path, {'imu': IMU, '/tf_static': TF_MESSAGE}, records)


def outputs(path: Path) -> tuple[np.ndarray, list]:
    """The body attitudes (w, x, y, z) of ``orientation`` and the ``imu/data`` messages."""
    with BagReader(path) as reader:
        body = [deserialize(data, 'geometry_msgs/msg/QuaternionStamped').quaternion
                for _, _, _, data in reader.messages(['orientation'])]
        imu = [deserialize(data, IMU) for _, _, _, data in reader.messages(['imu/data'])]
    return np.array([(q.w, q.x, q.y, q.z) for q in body]), imu


def test_a_chain_on_the_bags_tf_static_is_the_mount(tmp_path):
    """The body's attitude equals the replay of the body rates in ``base_link``;
    ``imu/data`` has frame ``imu_link``, the recorded rates and orientation body ⊗ mount."""
    mount = YAW * ROLL
    write_mounted_bag(tmp_path / 'mounted', 'imu_link', mount, [static_transforms(
        ('base_link', 'torso', YAW)), static_transforms(('torso', 'imu_link', ROLL))])
    write_mounted_bag(tmp_path / 'body', 'base_link', Rotation.identity(), [])
    mounted = replay_bag(tmp_path / 'mounted', tmp_path / 'out', ReplayOptions(**OPTIONS))
    reference = replay_bag(tmp_path / 'body', tmp_path / 'ref', ReplayOptions(**OPTIONS))
    assert mounted.rejected == reference.rejected and mounted.used == COUNT
    body, imu_data = outputs(tmp_path / 'out')
    reference_body, _ = outputs(tmp_path / 'ref')
    assert len(body) == len(imu_data) == COUNT
    assert np.max(np.abs(body - reference_body)) < 1e-12
    rate_sensor = mount.inv().apply(OMEGA_BODY)
    for q, message in zip(body, imu_data):
        assert message.header.frame_id == 'imu_link'
        got = message.orientation
        expected = (Rotation.from_quat([q[1], q[2], q[3], q[0]]) * mount).as_quat()
        assert abs(np.dot(expected, [got.x, got.y, got.z, got.w])) > 1.0 - 1e-14
        v = message.angular_velocity
        assert (v.x, v.y, v.z) == tuple(rate_sensor.tolist())
    assert any("mount 'base_link' -> 'imu_link' from the bag's /tf_static" in line
               for line in _info_lines(tmp_path / 'mounted', tmp_path / 'again'))


def _info_lines(bag: Path, out: Path) -> list[str]:
    lines: list[str] = []
    replay_bag(bag, out, ReplayOptions(**OPTIONS), log=lambda _, __, text: lines.append(text))
    return lines


def test_mount_rpy_wins_over_the_bags_tf_static(tmp_path):
    """With ``--mount-rpy`` the bag's transforms are not read (as the node ignores TF)."""
    mount = Rotation.from_euler('xyz', [0.0, 0.0, np.pi / 2])
    write_mounted_bag(tmp_path / 'in', 'imu_link', mount,
                      [static_transforms(('base_link', 'imu_link', ROLL))])
    result = replay_bag(tmp_path / 'in', tmp_path / 'out',
                        ReplayOptions(**OPTIONS, mount_rpy=(0.0, 0.0, np.pi / 2)))
    write_mounted_bag(tmp_path / 'body', 'base_link', Rotation.identity(), [])
    replay_bag(tmp_path / 'body', tmp_path / 'ref', ReplayOptions(**OPTIONS))
    assert result.used == COUNT
    assert np.max(np.abs(outputs(tmp_path / 'out')[0] - outputs(tmp_path / 'ref')[0])) < 1e-12


@pytest.mark.parametrize('tf_static', [[], [b'\x00\x01\x00\x00\xff\xff']])
def test_a_bag_without_the_transform_drops_every_sample_with_one_clear_line(
        tmp_path, capsys, tf_static):
    """No transform to ``imu_link`` (only one to a camera, and a malformed record): every
    sample dropped and counted ``no_mount``, one note naming both frames, no traceback."""
    records = [static_transforms(('base_link', 'camera_link', YAW)), *tf_static]
    write_mounted_bag(tmp_path / 'in', 'imu_link', YAW, records)
    code = main([str(tmp_path / 'in'), '-o', str(tmp_path / 'out'), '--scene', 'strapdown',
                 '--align-seconds', '0', '--no-progress'])
    captured = capsys.readouterr()
    assert code == 0 and 'Traceback' not in captured.err
    assert f'rejected: no_mount {COUNT}' in captured.out
    notes = [line for line in captured.out.splitlines()
             if "no static transform 'base_link' -> 'imu_link'" in line]
    assert len(notes) == 1 and '--mount-rpy' in notes[0] and notes[0].startswith('note:')
    assert ('1 malformed /tf_static records ignored' in captured.out) == bool(tf_static)
    with BagReader(tmp_path / 'out') as reader:
        assert reader.message_counts.get('orientation', 0) == 0


def test_a_first_record_in_a_foreign_frame_holds_up_nothing(tmp_path):
    """The first gyro records in ``other_imu`` (no mount in the bag), then the stream in
    ``imu_link`` (mounted by the bag's ``/tf_static``): as in the node, ``imu_link`` is the
    IMU's frame (the first with a known mount), every one of its records is used and the
    attitude equals the clean bag's; the ``other_imu`` records are refused ``foreign_frame``,
    those before the first ``imu_link`` one and those after it."""
    mount = YAW * ROLL
    rate_sensor = tuple(mount.inv().apply(OMEGA_BODY).tolist())
    mount_record = static_transforms(('base_link', 'imu_link', mount))
    records = [('/tf_static', START_NS - 1000, mount_record)]
    foreign = (9.0, 9.0, 9.0)
    records += [('imu', START_NS - 2000 + k,
                 encode_imu(START_NS - 2000 + k, 'other_imu', foreign)) for k in range(2)]
    records += [('imu', START_NS + k * PERIOD_NS,
                 encode_imu(START_NS + k * PERIOD_NS, 'imu_link', rate_sensor))
                for k in range(COUNT)]
    records.append(('imu', START_NS + COUNT * PERIOD_NS,
                    encode_imu(START_NS + COUNT * PERIOD_NS, 'other_imu', foreign)))
    write_records(tmp_path / 'in', {'imu': IMU, '/tf_static': TF_MESSAGE}, records)
    write_mounted_bag(tmp_path / 'clean', 'imu_link', mount, [mount_record])
    result = replay_bag(tmp_path / 'in', tmp_path / 'out', ReplayOptions(**OPTIONS))
    clean = replay_bag(tmp_path / 'clean', tmp_path / 'ref', ReplayOptions(**OPTIONS))
    assert result.used == clean.used == COUNT
    assert result.rejected == {**clean.rejected, 'foreign_frame': 3}
    body, imu_data = outputs(tmp_path / 'out')
    reference_body, _ = outputs(tmp_path / 'ref')
    assert len(body) == COUNT and np.array_equal(body, reference_body)
    assert {message.header.frame_id for message in imu_data} == {'imu_link'}
