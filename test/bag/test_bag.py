"""Tests of rigid_body_attitude.bag: round trips, batched writes, fast iteration, errors."""

import apsw
import numpy as np
import pytest
from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, Writer
import yaml

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.bag import mcap, rosbags_internals, sqlite
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.core.attitude.quaternion import normalize
from rigid_body_attitude.msgs import cdr

STORAGES = ['sqlite3', 'mcap']


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
        assert reader.topics == {'ground_truth': msgs.QUATERNION_STAMPED, 'imu': msgs.IMU,
                                 'rates': msgs.VECTOR3_STAMPED, 'torque': msgs.WRENCH_STAMPED}
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
    status = msgs.DiagnosticStatus(level=1, name='propagator', message='stale input',
                                   hardware_id='imu0', values={'dropped': '3', 'gap_s': '0.25'})
    with bag.BagWriter(path, storage=storage, custom_data={'k': 'v'}) as writer:
        connections = writer.add_topics({'orientation': msgs.QUATERNION_STAMPED,
                                         'energy': msgs.FLOAT64,
                                         'diagnostics': msgs.DIAGNOSTIC_ARRAY})
        for step in range(3):
            time_ns = 1_000 + step
            writer.write(connections['orientation'], time_ns,
                         cdr.encode_quaternion_stamped(time_ns, 'world', [1.0, 0.0, 0.0, 0.0]))
            writer.write(connections['energy'], time_ns, cdr.encode_float64(0.5 * step))
        writer.write(connections['diagnostics'], 2_000,
                     msgs.encode_diagnostic_array(2_000, '', [status]))
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
    types = {'imu': msgs.IMU, 'orientation': msgs.QUATERNION_STAMPED, 'energy': msgs.FLOAT64}
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
        energy = writer.add_topic('energy', msgs.FLOAT64).id
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
        bag.read_messages(path, {'imu': msgs.RATE_DECODERS, 'torque': msgs.RATE_DECODERS})
    with bag.BagReader(path) as reader:
        assert reader.decoder('imu', msgs.RATE_DECODERS) is msgs.decode_imu_motion
        assert reader.decoder('imu', bag.SERIES_DECODERS) is cdr.imu_rates
        assert reader.decoder('torque', msgs.TORQUE_DECODERS) is cdr.wrench_torque
        with pytest.raises(bag.BagError, match="has type 'sensor_msgs/msg/Imu'"):
            reader.decoder('imu', msgs.ATTITUDE_DECODERS)


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
        writer.add_topic('imu', msgs.IMU)
        with pytest.raises(bag.BagError, match="Topic 'imu' is already registered"):
            writer.add_topic('imu', msgs.IMU)
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
            connection = writer.add_connection('imu', msgs.IMU, typestore=bag.typestore())
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
