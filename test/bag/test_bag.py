"""Tests of rigid_body_attitude.bag: codecs against rosbags' serialiser, round trips, errors."""

import apsw
import numpy as np
import pytest
from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, Writer
import yaml

from rigid_body_attitude import bag
from rigid_body_attitude.bag import cdr, mcap, rosbags_internals, sqlite
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.core.quaternion import from_ros, normalize, to_ros

STORAGES = ['sqlite3', 'mcap']
# Frame ids whose CDR lengths (with NUL) 1, 2, 8, 9, 13 put the body after 0..7 pad bytes.
FRAME_IDS = ['', 'a', 'imu_lin', 'base_link', 'abcdefghijkl', 'ünïcode']
STAMP_NS = 1_700_000_123_456_789_012


def _types():
    return bag.typestore().types


def _header(stamp_ns, frame_id):
    types = _types()
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame_id)


def _vector3(values):
    return _types()['geometry_msgs/msg/Vector3'](x=values[0], y=values[1], z=values[2])


def _quaternion_msg(q_wxyz):
    x, y, z, w = to_ros(q_wxyz).tolist()
    return _types()['geometry_msgs/msg/Quaternion'](x=x, y=y, z=z, w=w)


def _reference_messages(frame_id):
    """(msgtype, rosbags message, our encoding) triples built from the same numbers."""
    types = _types()
    rng = np.random.default_rng(len(frame_id))
    rate, acceleration, force, torque, position = rng.normal(size=(5, 3)).tolist()
    attitude = normalize(rng.normal(size=4)).tolist()
    header = _header(STAMP_NS, frame_id)
    provided = np.zeros(9)
    not_provided = np.zeros(9)
    not_provided[0] = -1.0
    imu_full = types[bag.IMU](
        header=header, orientation=_quaternion_msg(attitude), orientation_covariance=provided,
        angular_velocity=_vector3(rate), angular_velocity_covariance=provided,
        linear_acceleration=_vector3(acceleration), linear_acceleration_covariance=provided)
    imu_rates_only = types[bag.IMU](
        header=header, orientation=_quaternion_msg([1.0, 0.0, 0.0, 0.0]),
        orientation_covariance=not_provided, angular_velocity=_vector3(rate),
        angular_velocity_covariance=provided, linear_acceleration=_vector3([0.0, 0.0, 0.0]),
        linear_acceleration_covariance=not_provided)
    pose = types['geometry_msgs/msg/Pose'](
        position=types['geometry_msgs/msg/Point'](x=position[0], y=position[1], z=position[2]),
        orientation=_quaternion_msg(attitude))
    return [
        (bag.IMU, imu_full, cdr.encode_imu(STAMP_NS, frame_id, rate, acceleration, attitude)),
        (bag.IMU, imu_rates_only, cdr.encode_imu(STAMP_NS, frame_id, rate)),
        (bag.VECTOR3_STAMPED, types[bag.VECTOR3_STAMPED](header=header, vector=_vector3(rate)),
         cdr.encode_vector3_stamped(STAMP_NS, frame_id, rate)),
        (bag.WRENCH_STAMPED, types[bag.WRENCH_STAMPED](
            header=header, wrench=types['geometry_msgs/msg/Wrench'](
                force=_vector3(force), torque=_vector3(torque))),
         cdr.encode_wrench_stamped(STAMP_NS, frame_id, force, torque)),
        (bag.TWIST_STAMPED, types[bag.TWIST_STAMPED](
            header=header, twist=types['geometry_msgs/msg/Twist'](
                linear=_vector3(force), angular=_vector3(rate))),
         cdr.encode_twist_stamped(STAMP_NS, frame_id, force, rate)),
        (bag.QUATERNION_STAMPED, types[bag.QUATERNION_STAMPED](
            header=header, quaternion=_quaternion_msg(attitude)),
         cdr.encode_quaternion_stamped(STAMP_NS, frame_id, attitude)),
        (bag.POSE_STAMPED, types[bag.POSE_STAMPED](header=header, pose=pose),
         cdr.encode_pose_stamped(STAMP_NS, frame_id, position, attitude)),
    ]


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_encoders_byte_equal_to_rosbags_serializer(frame_id):
    for msgtype, message, encoded in _reference_messages(frame_id):
        expected = bytes(bag.typestore().serialize_cdr(message, msgtype))
        assert encoded == expected, msgtype


def test_encode_float64_byte_equal_to_rosbags_serializer():
    for value in (0.0, -2.5, 1e300, float('inf')):
        message = _types()[bag.FLOAT64](data=value)
        expected = bytes(bag.typestore().serialize_cdr(message, bag.FLOAT64))
        assert cdr.encode_float64(value) == expected


def _decoded_fields(msgtype, message):
    """What our decoders must return for a rosbags message (stamps in s, (w, x, y, z))."""
    stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9

    def vec(v):
        return (v.x, v.y, v.z)

    def quat(q):
        return tuple(from_ros([q.x, q.y, q.z, q.w]).tolist())
    fields = {
        bag.IMU: lambda m: [(cdr.imu_rates, vec(m.angular_velocity)),
                            (cdr.imu_acceleration, vec(m.linear_acceleration))],
        bag.VECTOR3_STAMPED: lambda m: [(cdr.vector3_stamped, vec(m.vector))],
        bag.WRENCH_STAMPED: lambda m: [(cdr.wrench_force, vec(m.wrench.force)),
                                       (cdr.wrench_torque, vec(m.wrench.torque))],
        bag.TWIST_STAMPED: lambda m: [(cdr.twist_linear, vec(m.twist.linear)),
                                      (cdr.twist_angular, vec(m.twist.angular))],
        bag.QUATERNION_STAMPED: lambda m: [(cdr.quaternion_stamped, quat(m.quaternion))],
        bag.POSE_STAMPED: lambda m: [(cdr.pose_position, vec(m.pose.position)),
                                     (cdr.pose_orientation, quat(m.pose.orientation))],
    }[msgtype](message)
    return [(decoder, (stamp, value)) for decoder, value in fields]


@pytest.mark.parametrize('little_endian', [True, False])
@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_decoders_read_rosbags_serialized_messages(frame_id, little_endian):
    for msgtype, message, _ in _reference_messages(frame_id):
        data = bytes(bag.typestore().serialize_cdr(message, msgtype, little_endian=little_endian))
        for decoder, expected in _decoded_fields(msgtype, message):
            assert decoder(data) == expected, (msgtype, decoder.__name__)
        assert cdr.header_stamp_ns(data) == STAMP_NS
        assert cdr.header_frame_id(data) == frame_id


@pytest.mark.parametrize('little_endian', [True, False])
@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_gyro_decoders_read_the_integer_stamp_and_the_rate(frame_id, little_endian):
    sec, nanosec = divmod(STAMP_NS, 1_000_000_000)
    for msgtype, message, _ in _reference_messages(frame_id):
        if msgtype not in bag.GYRO_DECODERS:
            continue
        data = bytes(bag.typestore().serialize_cdr(message, msgtype, little_endian=little_endian))
        _, rate = bag.RATE_DECODERS[msgtype](data)
        assert bag.GYRO_DECODERS[msgtype](data) == (sec, nanosec, frame_id, rate), msgtype


def test_gyro_decoders_reject_what_the_rate_decoders_reject():
    imu = cdr.encode_imu(0, 'base_link', [1.0, 2.0, 3.0])
    decode = bag.GYRO_DECODERS[bag.IMU]
    for data, message in [(cdr.encode_vector3_stamped(0, 'base_link', [1.0, 2.0, 3.0]),
                           'malformed sensor_msgs/msg/Imu: truncated: 52 of 324 bytes'),
                          (imu[:100], 'truncated: 100 of 324 bytes'),
                          (imu[:2], 'truncated: 2 of at least 316 bytes'),
                          (b'\x00\x05' + imu[2:], 'bad encapsulation 0x0005')]:
        for decoder in (decode, cdr.imu_rates):
            with pytest.raises(bag.MalformedMessage, match=message):
                decoder(data)


@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_frame_encoders_give_the_general_encoders_bytes(frame_id):
    rng = np.random.default_rng(len(frame_id))
    encode_orientation = cdr.quaternion_stamped_encoder(frame_id)
    encode_pose = cdr.pose_stamped_encoder(frame_id)
    encode_vector = cdr.stamped_floats_encoder(frame_id, 3)
    encode_twist = cdr.stamped_floats_encoder(frame_id, 6)
    for stamp_ns in (0, STAMP_NS, 2 ** 31 * 1_000_000_000 - 1):
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        attitude = tuple(normalize(rng.normal(size=4)).tolist())
        position = tuple(rng.normal(size=3).tolist())
        assert encode_orientation(sec, nanosec, attitude) == cdr.encode_quaternion_stamped(
            stamp_ns, frame_id, attitude)
        assert encode_pose(sec, nanosec, position, attitude) == cdr.encode_pose_stamped(
            stamp_ns, frame_id, position, attitude)
        linear, angular = tuple(rng.normal(size=3).tolist()), tuple(rng.normal(size=3).tolist())
        assert encode_vector(sec, nanosec, linear) == cdr.encode_vector3_stamped(
            stamp_ns, frame_id, linear)
        assert encode_twist(sec, nanosec, linear + angular) == cdr.encode_twist_stamped(
            stamp_ns, frame_id, linear, angular)


def test_frame_encoders_reject_bad_frames_and_stamps():
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.quaternion_stamped_encoder('a\x00b')
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.pose_stamped_encoder(None)
    with pytest.raises(InputError, match='`sec` in int32 .* got sec=2147483648'):
        cdr.quaternion_stamped_encoder('world')(2 ** 31, 0, (1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='nanosec=-1'):
        cdr.pose_stamped_encoder('world')(0, -1, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.stamped_floats_encoder('a\x00b', 3)
    with pytest.raises(InputError, match='`sec` in int32 .* got sec=-2147483649'):
        cdr.stamped_floats_encoder('world', 3)(-2 ** 31 - 1, 0, (0.0, 0.0, 0.0))


@pytest.mark.parametrize('little_endian', [True, False])
@pytest.mark.parametrize('frame_id', FRAME_IDS)
def test_imu_with_orientation_sets_the_orientation_and_nothing_else(frame_id, little_endian):
    for msgtype, message, _ in _reference_messages(frame_id):
        if msgtype != bag.IMU:
            continue
        data = bytes(bag.typestore().serialize_cdr(message, msgtype, little_endian=little_endian))
        attitude = tuple(normalize([0.3, -0.1, 0.8, 0.5]).tolist())
        message.orientation = _quaternion_msg(attitude)
        message.orientation_covariance = np.zeros(9)
        expected = bytes(bag.typestore().serialize_cdr(message, msgtype,
                                                       little_endian=little_endian))
        assert cdr.imu_with_orientation(data, attitude) == expected
    with pytest.raises(bag.MalformedMessage, match='truncated: 52 of 324 bytes'):
        cdr.imu_with_orientation(cdr.encode_vector3_stamped(0, 'base_link', [1.0, 2.0, 3.0]),
                                 (1.0, 0.0, 0.0, 0.0))


def test_quaternion_codecs_agree_with_to_ros_and_from_ros():
    attitude = normalize([0.1, -0.7, 0.3, 0.5])
    message = bag.deserialize(cdr.encode_quaternion_stamped(0, 'world', attitude),
                              bag.QUATERNION_STAMPED)
    fields = [message.quaternion.x, message.quaternion.y, message.quaternion.z,
              message.quaternion.w]
    assert fields == to_ros(attitude).tolist()
    data = bag.serialize(message, bag.QUATERNION_STAMPED)
    assert list(cdr.quaternion_stamped(data)[1]) == from_ros(fields).tolist()


def test_imu_encoding_marks_missing_fields_per_rep145():
    message = bag.deserialize(cdr.encode_imu(5, 'imu', [1.0, 2.0, 3.0]), bag.IMU)
    assert message.orientation_covariance[0] == -1.0
    assert message.linear_acceleration_covariance[0] == -1.0
    assert message.angular_velocity_covariance.tolist() == [0.0] * 9
    full = bag.deserialize(cdr.encode_imu(5, 'imu', [1.0, 2.0, 3.0], [0.0, 0.0, 9.8],
                                          [1.0, 0.0, 0.0, 0.0]), bag.IMU)
    assert full.orientation_covariance[0] == 0.0
    assert full.linear_acceleration_covariance[0] == 0.0
    assert (full.header.stamp.sec, full.header.stamp.nanosec) == (0, 5)


def test_stamp_to_ns_keeps_epoch_resolution():
    assert cdr.stamp_to_ns(1.5) == 1_500_000_000
    assert cdr.stamp_to_ns(-0.25) == -250_000_000
    # 1.7e9 s: the float's own spacing is 2.4e-7 s; the fraction must survive to that level.
    stamp = 1_700_000_000.123456
    assert abs(cdr.stamp_to_ns(stamp) - 1_700_000_000_123_456_000) <= 240


def test_decoder_rejects_wrong_type_truncation_and_encapsulation():
    vector = cdr.encode_vector3_stamped(0, 'base_link', [1.0, 2.0, 3.0])
    with pytest.raises(bag.BagError, match='malformed sensor_msgs/msg/Imu: truncated: 52 of '
                                           '324 bytes'):
        cdr.imu_rates(vector)
    imu = cdr.encode_imu(0, 'base_link', [1.0, 2.0, 3.0])
    with pytest.raises(bag.BagError, match='truncated: 100 of 324 bytes'):
        cdr.imu_rates(imu[:100])
    with pytest.raises(bag.BagError, match='truncated: 2 of at least 316 bytes'):
        cdr.imu_rates(imu[:2])
    with pytest.raises(bag.BagError, match='bad encapsulation 0x0004'):
        cdr.imu_rates(b'\x00\x04' + imu[2:])
    with pytest.raises(bag.BagError, match='std_msgs/msg/Float64: truncated: 11 of 12 bytes'):
        cdr.float64_value(cdr.encode_float64(1.0)[:11])


def test_encoders_reject_bad_arguments():
    with pytest.raises(InputError, match='`angular_velocity` to have 3 components'):
        cdr.encode_imu(0, 'imu', [1.0, 2.0])
    with pytest.raises(InputError, match=r'`attitude` to be \(w, x, y, z\)'):
        cdr.encode_quaternion_stamped(0, 'world', [1.0, 0.0, 0.0])
    with pytest.raises(InputError, match='`stamp_ns` to be an integer'):
        cdr.encode_vector3_stamped(1.5, 'imu', [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match='`stamp_ns` to be an integer'):
        cdr.encode_vector3_stamped(2 ** 31 * 1_000_000_000, 'imu', [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match='`frame_id` to be a string without NUL'):
        cdr.encode_vector3_stamped(0, 'a\x00b', [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match='`value` to be a float'):
        cdr.encode_float64('one')


def _samples(count=50, seed=3):
    rng = np.random.default_rng(seed)
    stamps = 10.0 + 0.01 * np.arange(count)
    return dict(stamps=stamps, rates=rng.normal(size=(count, 3)),
                accelerations=rng.normal(size=(count, 3)), torques=rng.normal(size=(count, 3)),
                forces=rng.normal(size=(count, 3)),
                ground_truth=normalize(rng.normal(size=(count, 4))))


@pytest.mark.parametrize('storage', STORAGES)
def test_write_bag_round_trip(tmp_path, storage):
    samples = _samples()
    path = tmp_path / 'bag'
    counts = bag.write_bag(path, **samples, angular_velocity_topic='rates', storage=storage,
                           custom_data={'source': 'unit test'})
    assert counts == {'imu': 50, 'rates': 50, 'torque': 50, 'ground_truth': 50}
    with bag.BagReader(path) as reader:
        assert reader.topics == {'ground_truth': bag.QUATERNION_STAMPED, 'imu': bag.IMU,
                                 'rates': bag.VECTOR3_STAMPED, 'torque': bag.WRENCH_STAMPED}
        assert reader.custom_data == {'source': 'unit test'}
        messages = list(reader.messages(['imu', 'rates', 'torque', 'ground_truth']))
    assert len(messages) == 200
    stamps_ns = [cdr.stamp_to_ns(t) for t in samples['stamps']]
    by_topic = {}
    for topic, bag_time_ns, msgtype, data in messages:
        assert cdr.header_stamp_ns(data) == bag_time_ns
        by_topic.setdefault(topic, []).append((bag_time_ns, msgtype, data))
    for topic, decoder, key in [('imu', cdr.imu_rates, 'rates'),
                                ('imu', cdr.imu_acceleration, 'accelerations'),
                                ('rates', cdr.vector3_stamped, 'rates'),
                                ('torque', cdr.wrench_torque, 'torques'),
                                ('torque', cdr.wrench_force, 'forces'),
                                ('ground_truth', cdr.quaternion_stamped, 'ground_truth')]:
        rows = by_topic[topic]
        assert [t for t, _, _ in rows] == stamps_ns
        # The values travel as the same float64 bits: equality is exact.
        assert np.array_equal([decoder(data)[1] for _, _, data in rows], samples[key]), key
    frames = {topic: cdr.header_frame_id(rows[0][2]) for topic, rows in by_topic.items()}
    assert frames == {'imu': 'base_link', 'rates': 'base_link', 'torque': 'base_link',
                      'ground_truth': 'world'}


@pytest.mark.parametrize('storage', STORAGES)
def test_read_series_pose_ground_truth_and_lost_rows(tmp_path, storage):
    samples = _samples(count=20)
    ground_truth = samples['ground_truth'].copy()
    ground_truth[[3, 4, 11]] = np.nan
    path = tmp_path / 'bag'
    counts = bag.write_bag(path, stamps=samples['stamps'], ground_truth=ground_truth,
                           ground_truth_type='PoseStamped', storage=storage)
    assert counts == {'ground_truth': 17}
    series = bag.read_series(path, 'ground_truth')
    kept = np.ones(20, dtype=bool)
    kept[[3, 4, 11]] = False
    assert np.array_equal(series.values, ground_truth[kept])
    assert np.allclose(series.stamps, samples['stamps'][kept], rtol=0.0, atol=1e-9)
    assert np.array_equal(series.bag_times_ns,
                          [cdr.stamp_to_ns(t) for t in samples['stamps'][kept]])
    positions = [cdr.pose_position(data)[1]
                 for _, _, _, data in bag.read_messages(path, ['ground_truth'])]
    assert positions == [(0.0, 0.0, 0.0)] * 17


def test_write_bag_keeps_backward_and_jumping_stamps_in_receive_order(tmp_path):
    stamps = np.array([1.0, 1.01, 0.5, 1.02, 50.0, -3.0])
    receive_times = 2.0 + 0.01 * np.arange(6)
    rates = np.arange(18.0).reshape(6, 3)
    path = tmp_path / 'bad_stamps'
    bag.write_bag(path, stamps=stamps, rates=rates, receive_times=receive_times)
    series = bag.read_series(path, 'imu')
    assert np.allclose(series.stamps, stamps, rtol=0.0, atol=1e-9)
    assert np.array_equal(series.values, rates)
    assert np.array_equal(series.bag_times_ns, [cdr.stamp_to_ns(t) for t in receive_times])


def test_write_bag_without_validation_writes_nan_rates(tmp_path):
    rates = np.ones((3, 3))
    rates[1, 2] = np.nan
    path = tmp_path / 'nan'
    bag.write_bag(path, stamps=[0.0, 0.1, 0.2], rates=rates, validate=False)
    values = bag.read_series(path, 'imu').values
    assert np.isnan(values[1, 2]) and np.array_equal(values[[0, 2]], rates[[0, 2]])


@pytest.mark.parametrize('storage', STORAGES)
def test_bag_writer_output_topics_round_trip(tmp_path, storage):
    path = tmp_path / 'out'
    status = bag.DiagnosticStatus(level=1, name='propagator', message='stale input',
                                  hardware_id='imu0', values={'dropped': '3', 'gap_s': '0.25'})
    with bag.BagWriter(path, storage=storage, custom_data={'k': 'v'}) as writer:
        connections = writer.add_topics({'orientation': bag.QUATERNION_STAMPED,
                                         'energy': bag.FLOAT64,
                                         'diagnostics': bag.DIAGNOSTIC_ARRAY})
        for step in range(3):
            time_ns = 1_000 + step
            writer.write(connections['orientation'], time_ns,
                         cdr.encode_quaternion_stamped(time_ns, 'world', [1.0, 0.0, 0.0, 0.0]))
            writer.write(connections['energy'], time_ns, cdr.encode_float64(0.5 * step))
        writer.write(connections['diagnostics'], 2_000,
                     bag.encode_diagnostic_array(2_000, '', [status]))
    energy = bag.read_series(path, 'energy')
    assert energy.values[:, 0].tolist() == [0.0, 0.5, 1.0]
    assert energy.bag_times_ns.tolist() == [1_000, 1_001, 1_002]
    (_, _, msgtype, data), = bag.read_messages(path, ['diagnostics'])
    message = bag.deserialize(data, msgtype)
    assert message.status[0].level == 1 and message.status[0].message == 'stale input'
    pairs = [(v.key, v.value) for v in message.status[0].values]
    assert pairs == [('dropped', '3'), ('gap_s', '0.25')]
    assert yaml.safe_load((path / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']['custom_data'] == {'k': 'v'}


def _mixed_records(count):
    """``count`` (topic, bag time, CDR bytes) of three sizes with ties and times going back."""
    rng = np.random.default_rng(5)
    times = 1_000_000 + 1_000 * np.arange(count) - rng.integers(0, 3_000, count)
    times[::40] = times[1::40]
    records = []
    for index, time_ns in enumerate(times.tolist()):
        topic = ('imu', 'orientation', 'energy')[index % 3]
        if topic == 'imu':
            data = cdr.encode_imu(time_ns, 'imu_link', rng.normal(size=3).tolist())
        elif topic == 'orientation':
            data = cdr.encode_quaternion_stamped(time_ns, 'world', [1.0, 0.0, 0.0, 0.0])
        else:
            data = cdr.encode_float64(float(index))
        records.append((topic, time_ns, data))
    return records


def _sqlite_rows(path):
    import sqlite3  # the standard module, as other tools would read the file
    connection = sqlite3.connect(next(path.glob('*.db3')))
    try:
        return (connection.execute('SELECT * FROM topics ORDER BY id').fetchall(),
                connection.execute('SELECT id, topic_id, timestamp, data FROM messages '
                                   'ORDER BY id').fetchall())
    finally:
        connection.close()


@pytest.mark.parametrize('storage', STORAGES)
def test_write_many_makes_the_bag_single_rosbags_writes_make(tmp_path, storage):
    # 21000 records (about 3.3 MiB) span four MCAP chunks of 1 MiB; batches of varied sizes
    # (one of 1, an empty one, single writes between them) end anywhere inside a chunk.
    records = _mixed_records(21_000)
    types = {'imu': bag.IMU, 'orientation': bag.QUATERNION_STAMPED, 'energy': bag.FLOAT64}
    reference = tmp_path / 'reference' / 'bag'
    with Writer(reference, version=9, storage_plugin=bag.STORAGES[storage]) as writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=bag.typestore())
                       for topic, msgtype in types.items()}
        for topic, time_ns, data in records:
            writer.write(connections[topic], time_ns, data)
    ours = tmp_path / 'ours' / 'bag'
    with bag.BagWriter(ours, storage=storage) as writer:
        connections = writer.add_topics(types)
        begin = 0
        for end, single_after in [(1, False), (1, False), (2, True), (700, False),
                                  (9_001, False), (9_002, True), (15_000, False),
                                  (21_000, False)]:
            writer.write_many([(connections[topic].id, time_ns, data)
                               for topic, time_ns, data in records[begin:end]])
            begin = end
            if single_after:
                topic, time_ns, data = records[begin]
                writer.write(connections[topic], time_ns, data)
                begin += 1
    assert (ours / 'metadata.yaml').read_text() == (reference / 'metadata.yaml').read_text()
    metadata = yaml.safe_load((ours / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert metadata['message_count'] == len(records)
    assert {entry['topic_metadata']['name']: entry['message_count']
            for entry in metadata['topics_with_message_count']} == {
        'imu': 7_000, 'orientation': 7_000, 'energy': 7_000}
    times = [time_ns for _, time_ns, _ in records]
    assert metadata['starting_time']['nanoseconds_since_epoch'] == min(times)
    assert metadata['duration']['nanoseconds'] == max(times) - min(times)
    if storage == 'mcap':
        assert (ours / 'bag.mcap').read_bytes() == (reference / 'bag.mcap').read_bytes()
    else:
        assert _sqlite_rows(ours) == _sqlite_rows(reference)
        database = apsw.Connection(str(next(ours.glob('*.db3'))))
        assert database.execute('PRAGMA page_size').fetchall() == [(32768,)]
        assert database.execute('PRAGMA integrity_check').fetchall() == [('ok',)]
        database.close()
    expected = _rosbags_messages(reference, set(types))
    assert len(expected) == len(records)
    assert _rosbags_messages(ours, set(types)) == expected
    with bag.BagReader(ours) as reader:
        assert list(reader.messages(list(types))) == expected


@pytest.mark.parametrize('storage', STORAGES)
def test_write_many_rejects_a_bad_batch_whole(tmp_path, storage):
    path = tmp_path / 'bag'
    data = cdr.encode_float64(1.0)
    with bag.BagWriter(path, storage=storage) as writer:
        energy = writer.add_topic('energy', bag.FLOAT64).id
        writer.write_many([(energy, 5, data)])
        for batch, message in [
                ([(energy, 6, data), (energy + 7, 7, data)],
                 r'ids of its topics \[1\].* ids \[8\]'),
                ([(energy, 6, data), (energy, -1, data)], r'times in \[0, 2\*\*63\).*\[-1, 6\]'),
                ([(energy, 6, data), (energy, 2 ** 63, data)],
                 r'times \[6, 9223372036854775808\]'),
                ([(energy, 6, data), (energy, 7.0, data)], 'integer bag time in'),
                ([(energy, 6, data), (energy, 7)], 'expected records'),
                ([(energy, 6, data), (energy, 7, 'text')], r"data of types \['bytes', 'str'\]")]:
            with pytest.raises(bag.BagError, match=message):
                writer.write_many(batch)
    with pytest.raises(bag.BagError, match='expected an open bag'):
        writer.write_many([(energy, 8, data)])
    series = bag.read_series(path, 'energy')
    assert series.bag_times_ns.tolist() == [5]
    assert yaml.safe_load((path / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']['message_count'] == 1


def test_reader_errors_missing_path_and_directory_without_metadata(tmp_path):
    with pytest.raises(bag.BagError, match='does not exist'):
        bag.BagReader(tmp_path / 'nowhere')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(bag.BagError, match='metadata file .* does not exist'):
        bag.read_messages(tmp_path / 'empty', ['imu'])
    (tmp_path / 'notes.txt').write_text('not a bag')
    with pytest.raises(bag.BagError, match="Unrecognized storage format '.txt'"):
        bag.BagReader(tmp_path / 'notes.txt')


def test_reader_error_unknown_storage_plugin(tmp_path):
    path = tmp_path / 'bag'
    bag.write_bag(path, stamps=[0.0], rates=[[0.0, 0.0, 1.0]])
    metadata = path / 'metadata.yaml'
    metadata.write_text(metadata.read_text().replace('storage_identifier: sqlite3',
                                                     'storage_identifier: rosbag_v1'))
    with pytest.raises(bag.BagError, match="Storage plugin 'rosbag_v1' not supported"):
        bag.BagReader(path)


def test_reader_error_missing_topic_lists_topics_with_types(tmp_path):
    path = tmp_path / 'bag'
    bag.write_bag(path, stamps=[0.0, 1.0], rates=np.zeros((2, 3)), torques=np.zeros((2, 3)))
    expected = ("Topic 'gyro' is not in bag .*; it has: imu \\(sensor_msgs/msg/Imu\\), "
                "torque \\(geometry_msgs/msg/WrenchStamped\\)")
    with pytest.raises(bag.BagError, match=expected):
        bag.read_messages(path, ['imu', 'gyro'])


def test_reader_error_unusable_message_type(tmp_path):
    path = tmp_path / 'bag'
    bag.write_bag(path, stamps=[0.0], rates=[[0.0, 0.0, 1.0]], torques=[[1.0, 0.0, 0.0]])
    with pytest.raises(bag.BagError, match="Topic 'torque' .* has type "
                                           "'geometry_msgs/msg/WrenchStamped'; expected one of"):
        bag.read_messages(path, {'imu': bag.RATE_DECODERS, 'torque': bag.RATE_DECODERS})
    with bag.BagReader(path) as reader:
        assert reader.decoder('imu', bag.RATE_DECODERS) is cdr.imu_rates
        assert reader.decoder('torque', bag.TORQUE_DECODERS) is cdr.wrench_torque
        with pytest.raises(bag.BagError, match="has type 'sensor_msgs/msg/Imu'"):
            reader.decoder('imu', bag.ATTITUDE_DECODERS)


def test_bag_error_is_a_project_error():
    assert issubclass(bag.BagError, AttitudeError) and issubclass(bag.BagError, ValueError)


def test_writer_errors(tmp_path):
    path = tmp_path / 'bag'
    path.mkdir()
    with pytest.raises(bag.BagError, match='exists already'):
        bag.BagWriter(path)
    with pytest.raises(InputError, match=r"`storage` to be one of \['mcap', 'sqlite3'\]"):
        bag.BagWriter(tmp_path / 'other', storage='rosbag1')
    assert not (tmp_path / 'other').exists()
    with bag.BagWriter(tmp_path / 'fresh') as writer:
        writer.add_topic('imu', bag.IMU)
        with pytest.raises(bag.BagError, match="Topic 'imu' is already registered"):
            writer.add_topic('imu', bag.IMU)
        with pytest.raises(bag.BagError, match="ROS 2 Jazzy message type .* got 'my_msgs/Foo'"):
            writer.add_topic('foo', 'my_msgs/Foo')


@pytest.mark.parametrize('changes, message', [
    (dict(rates=np.zeros((4, 3))), r'`rates` to have shape \(5, 3\)'),
    (dict(ground_truth=np.ones((5, 3))), r'`ground_truth` to have shape \(5, 4\)'),
    (dict(stamps=np.zeros((5, 1))), r'`stamps` to have shape \(N,\)'),
    (dict(stamps=[0.0, 1.0, np.nan, 2.0, 3.0]), '`stamps` to be finite'),
    (dict(stamps=np.full(5, 3e9)), '`stamps` within the int32 seconds range'),
    (dict(torques=np.full((5, 3), np.inf)), '`torques` to be finite'),
    (dict(ground_truth=np.full((5, 4), 0.6)), '`ground_truth` to be unit quaternions'),
    (dict(ground_truth=np.array([[1.0, 0.0, 0.0, np.nan]] * 5)),
     '`ground_truth` rows to be finite or all NaN'),
    (dict(receive_times=np.arange(4.0)), r'`receive_times` to have shape \(5,\)'),
    (dict(stamps=np.arange(5.0) - 1.0), '`receive_times` \\(default: `stamps`\\) to be ≥ 0'),
    (dict(rates=None, torques=None, ground_truth=None), 'at least one of `rates`'),
    (dict(accelerations=np.zeros((5, 3)), imu_topic=None, angular_velocity_topic='w'),
     '`imu_topic` for `accelerations`'),
    (dict(imu_topic=None), '`imu_topic` or `angular_velocity_topic` for `rates`'),
    (dict(angular_velocity_topic='imu'), 'distinct topics'),
    (dict(torque_topic=''), '`torque_topic` to be a non-empty string'),
    (dict(ground_truth_type='Odometry'), '`ground_truth_type` to be one of'),
    (dict(storage='db3'), '`storage` to be one of'),
    (dict(frame_id=3), '`frame_id` to be a string'),
])
def test_write_bag_rejects_bad_input_without_creating_the_bag(tmp_path, changes, message):
    arguments = dict(stamps=np.arange(5.0), rates=np.zeros((5, 3)), torques=np.zeros((5, 3)),
                     ground_truth=np.tile([1.0, 0.0, 0.0, 0.0], (5, 1)))
    arguments.update(changes)
    with pytest.raises(InputError, match=message):
        bag.write_bag(tmp_path / 'bag', **arguments)
    assert not (tmp_path / 'bag').exists()


def _rosbags_messages(path, topics):
    """The reference sequence: rosbags' own reader, as (topic, time, msgtype, bytes)."""
    with Reader(path) as reader:
        connections = [c for c in reader.connections if c.topic in topics]
        return [(c.topic, t, c.msgtype, bytes(data))
                for c, t, data in reader.messages(connections)]


@pytest.mark.parametrize('receive_order', ['monotonic', 'shuffled', 'halves_swapped'])
def test_mcap_fast_iteration_matches_rosbags(tmp_path, receive_order):
    # 5000 Imu messages of 324 B fill two 1 MiB chunks. Every 50th receive time repeats its
    # neighbour's (ties). 'shuffled' permutes receive times within blocks of 7 (out of order
    # inside a chunk, chunks touching); 'halves_swapped' also records the second half before
    # the first, so the chunks overlap in time.
    count = 5000
    rng = np.random.default_rng(11)
    receive = 1.0 + 1e-3 * np.arange(count)
    if receive_order != 'monotonic':
        receive = 1.0 + 1e-3 * (np.arange(count) // 7 * 7 + rng.integers(0, 7, count))
    receive[::50] = receive[1::50]
    if receive_order == 'halves_swapped':
        receive[count // 2:] -= 2.6
    path = tmp_path / 'bag'
    bag.write_bag(path, stamps=np.arange(count) * 1e-3, rates=rng.normal(size=(count, 3)),
                  ground_truth=np.tile([1.0, 0.0, 0.0, 0.0], (count, 1)),
                  receive_times=receive, storage='mcap')
    with bag.BagReader(path) as reader:
        assert mcap.fast_messages(reader._reader, reader.connections(['imu']))
        chunks = sorted(rosbags_internals.mcap_files(reader._reader)[0].chunks,
                        key=lambda chunk: chunk.message_start_time)
        assert len(chunks) >= 2
        overlap = chunks[0].message_end_time - chunks[1].message_start_time
        assert (overlap > 1_000_000_000) == (receive_order == 'halves_swapped')
        ours = list(reader.messages(['imu', 'ground_truth']))
        imu_only = list(reader.messages(['imu']))
    assert ours == _rosbags_messages(path, {'imu', 'ground_truth'})
    assert imu_only == _rosbags_messages(path, {'imu'})
    assert [t for _, t, _, _ in ours] == sorted(t for _, t, _, _ in ours)


@pytest.mark.parametrize('receive_order', ['monotonic', 'shuffled'])
def test_sqlite_fast_iteration_matches_rosbags(tmp_path, receive_order):
    # Every 50th receive time repeats its neighbour's (ties across topics and within one);
    # 'shuffled' records out of time order. Also the bare .db3 file and a topic subset.
    count = 3000
    rng = np.random.default_rng(12)
    receive = 1.0 + 1e-3 * np.arange(count)
    if receive_order == 'shuffled':
        receive = 1.0 + 1e-3 * rng.permutation(count)
    receive[::50] = receive[1::50]
    path = tmp_path / 'bag'
    bag.write_bag(path, stamps=np.arange(count) * 1e-3, rates=rng.normal(size=(count, 3)),
                  torques=rng.normal(size=(count, 3)),
                  ground_truth=np.tile([1.0, 0.0, 0.0, 0.0], (count, 1)), receive_times=receive)
    topics = ['imu', 'torque', 'ground_truth']
    for target in (path, next(path.glob('*.db3'))):
        with bag.BagReader(target) as reader:
            assert sqlite.fast_messages(reader._reader, reader.connections(topics))
            ours = list(reader.messages(topics))
            subset = list(reader.messages(['ground_truth', 'imu']))
        assert ours == _rosbags_messages(target, set(topics))
        assert subset == _rosbags_messages(target, {'imu', 'ground_truth'})
        assert len(ours) == 3 * count and len(subset) == 2 * count
        assert [t for _, t, _, _ in ours] == sorted(t for _, t, _, _ in ours)


def test_fast_iteration_declines_what_it_does_not_handle(tmp_path):
    paths = {}
    for storage in ('mcap', 'sqlite3'):
        paths[storage] = tmp_path / f'message_compressed_{storage}'
        writer = Writer(paths[storage], version=9, storage_plugin=bag.STORAGES[storage])
        writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
        with writer:
            connection = writer.add_connection('imu', bag.IMU, typestore=bag.typestore())
            for step in range(3):
                writer.write(connection, step, cdr.encode_imu(step, 'imu', [step, 0.0, 0.0]))
    plain_sqlite = tmp_path / 'sqlite'
    bag.write_bag(plain_sqlite, stamps=[0.0, 1.0], rates=np.zeros((2, 3)))
    plain_mcap = tmp_path / 'mcap'
    bag.write_bag(plain_mcap, stamps=[0.0, 1.0], rates=np.zeros((2, 3)), storage='mcap')
    for path, module in [(paths['mcap'], mcap), (paths['sqlite3'], mcap),
                         (paths['sqlite3'], sqlite), (paths['mcap'], sqlite),
                         (plain_sqlite, mcap), (plain_mcap, sqlite)]:
        with bag.BagReader(path) as reader:
            assert module.fast_messages(reader._reader, reader.connections(['imu'])) is None
            assert list(reader.messages(['imu'])) == _rosbags_messages(path, {'imu'})
    for path in paths.values():
        rates = bag.read_series(path, 'imu').values
        assert rates[:, 0].tolist() == [0.0, 1.0, 2.0]
