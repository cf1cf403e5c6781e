"""Tests of rigid_body_attitude.tools.replay offline: outputs, time rules, report files, errors.

The live comparison with the node is in ``test_replay_live.py``, real data in
``test_real_data.py``.
"""

from __future__ import annotations

import csv
from pathlib import Path
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bag_fixtures import build_case, write_case_bag, write_scene
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.bag import BagError, BagReader, deserialize, read_series, write_bag
from rigid_body_attitude.msgs import IMU, POSE_STAMPED, QUATERNION_STAMPED, header_stamp_ns
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.tools.replay import (
    ReplayOptions, attitude_errors, main, replay_bag, summary)
from rigid_body_attitude.session.parameters import PARAMETERS
from rigid_body_attitude.tools.replay.options import TF_PARAMETERS, WALL_PARAMETERS
from rigid_body_attitude.session.interface import NODE_INTERFACE
from rigid_body_attitude.session.settings import timer_period_ns

RATE = 1000.0
OMEGA = np.array([0.4, -1.1, 2.3])
GYRO_SCENE = 'strapdown'


def constant_rate_bag(path: Path, count: int = 200, start: float = 10.0, **kwargs) -> Path:
    """``count`` Imu samples of OMEGA at 1 kHz from ``start`` (and the exact attitude)."""
    stamps = start + np.arange(count) / RATE
    truth = quaternion.exp(np.multiply.outer(stamps - start, OMEGA))
    write_bag(path, stamps=stamps, rates=np.tile(OMEGA, (count, 1)), ground_truth=truth,
              **kwargs)
    return path


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv + ['--no-progress'])
    captured = capsys.readouterr()
    assert 'Traceback' not in captured.err
    return code, captured.out, captured.err


def test_options_are_the_node_parameters_with_their_defaults():
    options = ReplayOptions().parameters()
    assert options == {p.name: p.default for p in PARAMETERS
                       if p.name not in TF_PARAMETERS + WALL_PARAMETERS}
    # Wall pacing means nothing on a bag's time axis; lockstep does (ticks on command stamps).
    assert WALL_PARAMETERS == ('publish_clock', 'real_time_factor', 'lockstep_timeout')
    assert 'lockstep' in options
    assert TF_PARAMETERS == ('publish_tf', 'tf_rate', 'tf_timeout')  # a bag has no TF to read
    assert 'max_angular_rate' in options
    # From Python an integer may stand for a double; a boolean may not.
    assert ReplayOptions(publish_rate=100).parameters()['publish_rate'] == 100.0
    assert type(ReplayOptions(publish_rate=100).parameters()['publish_rate']) is float
    with pytest.raises(InputError, match='Expected parameter `max_dt` to be a double'):
        replay_bag('unused', 'unused', ReplayOptions(max_dt=True))
    # rclpy's create_timer(1 / rate): 50 Hz → 20 ms; 30 Hz truncates to 33333333 ns.
    assert timer_period_ns(50.0) == 20_000_000
    assert timer_period_ns(30.0) == 33_333_333


@pytest.mark.parametrize('storage', ['sqlite3', 'mcap'])
def test_main_writes_the_node_outputs_and_a_summary(tmp_path, capsys, storage):
    bag = constant_rate_bag(tmp_path / 'in', storage=storage)
    out = tmp_path / 'out'
    code, text, _ = run([str(bag), '-o', str(out), '--scene', GYRO_SCENE, '--storage', storage],
                        capsys)
    assert code == 0
    with BagReader(out) as reader:
        topics, counts = reader.topics, reader.message_counts
    assert topics == {name: NODE_INTERFACE.endpoint(name, 'out').type for name in
                      ('orientation', 'pose', 'pose_with_covariance', 'imu/data',
                       '/diagnostics')}
    assert counts['orientation'] == counts['pose'] == counts['imu/data'] == 200
    assert counts['pose_with_covariance'] == 200
    # A gyro scene simulates no body: no energy or angular momentum; diagnostics once, at the
    # second after the first sample (the bag spans 0.2 s).
    assert counts['/diagnostics'] == 1
    series = read_series(out, 'orientation')
    assert series.stamps == pytest.approx(10.0 + np.arange(200) / RATE, abs=1e-9)
    expected = quaternion.exp(np.multiply.outer(np.arange(200) / RATE, OMEGA))
    assert np.max(np.abs(series.values - expected)) < 1e-13
    for expected_text in ('read: imu 200', 'used: 200; rejected: none',
                          'written: orientation 200, pose 200, pose_with_covariance 200, '
                          'imu/data 200, /diagnostics 1',
                          'final attitude (w, x, y, z) at stamp 10.199000000 s',
                          'final state: rotation ', 'gyro messages in'):
        assert expected_text in text


def test_series_are_kept_when_asked_or_needed_and_change_nothing_else(tmp_path):
    bag = constant_rate_bag(tmp_path / 'in')
    kept = replay_bag(bag, tmp_path / 'kept', ReplayOptions(scene=GYRO_SCENE))
    lean = replay_bag(bag, tmp_path / 'lean', ReplayOptions(scene=GYRO_SCENE),
                      keep_series=False)
    assert len(kept.series.attitude_stamps_ns) == 200
    assert len(lean.series.attitude_stamps_ns) == len(lean.series.energies) == 0
    assert lean.final_stamp_ns == kept.final_stamp_ns == kept.series.attitude_stamps_ns[-1]
    assert lean.final_attitude == kept.final_attitude
    assert lean.written == kept.written
    # The summaries differ only in the output path and the timing line.
    assert summary(lean).splitlines()[1:-1] == summary(kept).splitlines()[1:-1]
    with BagReader(tmp_path / 'kept') as first, BagReader(tmp_path / 'lean') as second:
        topics = list(first.topics)
        assert list(first.messages(topics)) == list(second.messages(topics))
    truth = replay_bag(bag, tmp_path / 'truth',
                       ReplayOptions(scene=GYRO_SCENE, ground_truth_topic='ground_truth'),
                       keep_series=False)
    assert len(truth.series.attitude_stamps_ns) == 200 and truth.errors.count == 200


MOUNT_RPY = (0.3, -0.2, 1.2)


@pytest.mark.parametrize('frame_id, mount_rpy', [('base_link', None), ('imu_link', MOUNT_RPY)])
def test_imu_data_is_the_input_with_the_sensor_frames_orientation(tmp_path, capsys, frame_id,
                                                                  mount_rpy):
    """``imu/data`` keeps the input's frame, rates and accelerations (the sensor's, REP-145);
    its orientation is the sensor frame's, the body's composed with the mount (scipy's
    product here), its covariance the body's (about fixed world axes: the mount turns none)."""
    stamps = 3.0 + np.arange(5) / RATE
    acceleration = np.array([[0.1, -9.8, 0.3]] * 5)
    bag = tmp_path / 'in'
    write_bag(bag, stamps=stamps, rates=np.tile(OMEGA, (5, 1)), accelerations=acceleration,
              frame_id=frame_id)
    mount = ['--mount-rpy', str(list(mount_rpy))] if mount_rpy else []
    assert run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE, '--align-seconds',
                '0', *mount],
               capsys)[0] == 0
    with BagReader(tmp_path / 'out') as reader:
        imu_data = [deserialize(data, IMU) for _, _, _, data in reader.messages(['imu/data'])]
    orientations = read_series(tmp_path / 'out', 'orientation').values
    assert len(imu_data) == len(orientations) == 5
    q_body_sensor = Rotation.from_euler('xyz', mount_rpy or (0.0, 0.0, 0.0))
    for message, q in zip(imu_data, orientations):
        assert message.header.frame_id == frame_id
        w, x, y, z = q
        expected = (Rotation.from_quat([x, y, z, w]) * q_body_sensor).as_quat()
        got = message.orientation
        assert abs(np.dot(expected, [got.x, got.y, got.z, got.w])) > 1.0 - 1e-15
        if mount_rpy is None:
            assert (got.w, got.x, got.y, got.z) == tuple(q)
        # Unlevelled, before the first fold: the prior, tilt and yaw unknown (1σ π rad).
        assert message.orientation_covariance.tolist() == (np.eye(3) * np.pi ** 2).reshape(
            9).tolist()
        assert message.linear_acceleration.y == -9.8
        assert message.linear_acceleration_covariance[0] == 0.0  # given, so not -1
        assert (message.angular_velocity.x, message.angular_velocity.y,
                message.angular_velocity.z) == tuple(OMEGA)


def test_rejections_follow_the_stream_rules_and_are_counted(tmp_path, capsys):
    # Receive order: 0..4 ms, NaN at 5 ms, a repeat of 4 ms (stale), 6 ms, an outlier at
    # 900 ms that the next sample (7 ms) refutes, a gap to 500 ms confirmed by 501 and 502 ms,
    # then a jump back by 400 ms (> 0.2 s threshold: reset) confirmed by 102 and 103 ms.
    stamps = np.array([0, 1, 2, 3, 4, 5, 4, 6, 900, 7, 500, 501, 502, 101, 102, 103]) * 1e-3
    stamps += 20.0
    rates = np.tile(OMEGA, (stamps.size, 1))
    rates[5] = np.nan
    receive = 30.0 + np.arange(stamps.size) * 1e-3
    bag = tmp_path / 'in'
    write_bag(bag, stamps=stamps, rates=rates, receive_times=receive, validate=False)
    code, text, err = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE,
                           '--time-jump-threshold', '0.2'], capsys)
    assert code == 0
    assert ('rejected: gap 1, non_finite 1, outlier_stamp 1, stale_stamp 1, time_jump 1'
            in text)
    # Published: every sample used, a jump once confirmed (at the confirming sample's stamp);
    # not the NaN, the stale repeat, the outlier or the samples waiting for confirmation.
    series = read_series(tmp_path / 'out', 'orientation')
    published = np.array([0, 1, 2, 3, 4, 6, 7, 502, 103]) * 1e-3 + 20.0
    assert series.stamps == pytest.approx(published, abs=1e-9)
    q = series.values
    # 0 → 7 ms integrated (the NaN and the outlier skipped: a constant rate, so exact).
    assert quaternion.attitude_error(q[6], quaternion.exp(OMEGA * 7e-3)) < 1e-14
    # Not integrated across the gap: from 7 ms's attitude, 500 → 502 ms only.
    expected = quaternion.multiply(q[6], quaternion.exp(OMEGA * 2e-3))
    assert quaternion.attitude_error(q[7], expected) < 1e-14
    # The jump back resets to the scene's initial attitude at 101 ms, integrated to 103 ms.
    assert quaternion.attitude_error(q[8], quaternion.exp(OMEGA * 2e-3)) < 1e-14
    # The session's warnings reach stderr (bag time), the summary counts them.
    assert '[WARN] bag time 30.005 s: gyro: a non-finite rate' in err
    assert 'stamps jumped back by more than time_jump_threshold' in err
    assert 'logged: 5 warnings, 0 errors' in text


def test_no_header_stamps_integrates_on_the_bag_times(tmp_path, capsys):
    stamps = np.zeros(50)  # a driver that does not stamp
    receive = 7.0 + np.arange(50) * 2e-3
    bag = tmp_path / 'in'
    write_bag(bag, stamps=stamps, rates=np.tile(OMEGA, (50, 1)), receive_times=receive)
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE,
                         '--no-header-stamps'], capsys)
    assert code == 0 and 'rejected: none' in text
    series = read_series(tmp_path / 'out', 'orientation')
    assert series.stamps == pytest.approx(receive, abs=1e-9)
    assert quaternion.attitude_error(series.values[-1], quaternion.exp(OMEGA * 49 * 2e-3)) \
        < 1e-14
    # With header stamps the node refuses zero stamps (unstamped input): nothing is used.
    code, text, err = run([str(bag), '-o', str(tmp_path / 'stale'), '--scene', GYRO_SCENE],
                          capsys)
    assert code == 0 and 'used: 0; rejected: zero_stamp 50' in text
    assert 'logged: 1 warnings' in text and 'set use_header_stamps:=false' in err


def test_dynamics_ticks_at_the_period_multiples_within_the_bag(tmp_path, capsys):
    case = build_case('constant_torque')
    bag = tmp_path / 'in'
    write_case_bag(case, bag)
    scene = write_scene(case, tmp_path)
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', str(scene),
                         '--publish-rate', '40'], capsys)
    assert code == 0
    stamps_ns = [header_stamp_ns(data) for _, _, _, data in
                 BagReader(tmp_path / 'out').messages(['pose'])]
    # 40 Hz → 25 ms; commands from 100.000 s to 101.950 s: ticks 100.000 ... 101.950.
    assert stamps_ns == list(range(100_000_000_000, 101_950_000_001, 25_000_000))
    assert 'read: ground_truth 40, torque 40' in text
    # 40 commands used, 79 ticks.
    assert 'used: 40; clock ticks: 79; rejected: none' in text


def test_dynamics_bag_shorter_than_a_period_is_noted(tmp_path, capsys):
    case = build_case('torque_free')
    bag = tmp_path / 'in'
    write_bag(bag, stamps=[100.001, 100.002], ground_truth=case.attitude(np.zeros(2)))
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', 'torque_free_box'],
                        capsys)
    assert code == 0 and 'written: orientation 0' in text
    assert "note: no clock tick within the bag's time span at publish_rate 50 Hz" in text


def test_ground_truth_statistics_csv_and_plot(tmp_path, capsys):
    bag = constant_rate_bag(tmp_path / 'in')
    out, table = tmp_path / 'out', tmp_path / 'values.csv'
    code, text, _ = run([str(bag), '-o', str(out), '--scene', GYRO_SCENE, '--ground-truth',
                         'ground_truth', '--csv', str(table)], capsys)
    assert code == 0
    assert 'attitude error vs ground truth: max' in text and '(200 samples)' in text
    plot = Path(str(out) + '_error.png')
    assert plot.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    with open(table, encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 200 and rows[0]['stamp_s'] == '10.000000000'
    assert float(rows[-1]['qw']) == pytest.approx(
        quaternion.exp(OMEGA * 0.199)[0], abs=1e-12)
    # A gyro scene simulates no body: no energy or momentum columns.
    assert list(rows[0]) == ['stamp_s', 'qw', 'qx', 'qy', 'qz', 'px', 'py', 'pz']
    with open(tmp_path / 'values_error.csv', encoding='utf-8') as stream:
        errors = [float(row['attitude_error_rad']) for row in csv.DictReader(stream)]
    assert len(errors) == 200 and max(errors) < 1e-13


def test_start_from_ground_truth_sets_the_attitude_there(tmp_path):
    stamps = 5.0 + np.arange(100) / RATE
    truth = quaternion.multiply(quaternion.normalize([0.3, -0.5, 0.1, 0.8]),
                                quaternion.exp(np.multiply.outer(stamps - 5.0, OMEGA)))
    bag = tmp_path / 'in'
    write_bag(bag, stamps=stamps, rates=np.tile(OMEGA, (100, 1)), ground_truth=truth,
              ground_truth_type='PoseStamped')
    options = ReplayOptions(scene=GYRO_SCENE, ground_truth_topic='ground_truth',
                            start_from_ground_truth=5.0405)
    result = replay_bag(bag, tmp_path / 'out', options)
    assert result.alignment_stamp_ns == 5_041_000_000
    # Errors from the alignment on only (before it the scene's identity start was off by the
    # truth's initial rotation, 2.7 rad).
    assert result.errors.stamps_ns[0] == result.alignment_stamp_ns
    assert result.errors.count == 59 and result.errors.errors.max() < 1e-13
    assert 'attitude set from the ground truth at stamp 5.041000000 s' in summary(result)
    without = replay_bag(bag, tmp_path / 'plain', ReplayOptions(
        scene=GYRO_SCENE, ground_truth_topic='ground_truth'))
    assert without.errors.count == 100
    assert without.errors.errors[0] == pytest.approx(
        quaternion.attitude_error(truth[0], quaternion.identity()), abs=1e-12)


def test_set_pose_reinitialises_the_attitude_as_in_the_node(tmp_path, capsys):
    stamps = 2.0 + np.arange(20) / RATE
    poses = np.full((20, 4), np.nan)
    target = quaternion.normalize([0.1, 0.7, -0.7, 0.1])
    poses[9] = target  # set_pose recorded right after the gyro sample at 2.009 s
    bag = tmp_path / 'in'
    write_bag(bag, stamps=stamps, rates=np.tile(OMEGA, (20, 1)), ground_truth=poses,
              ground_truth_topic='set_pose', ground_truth_type='PoseStamped')
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE],
                        capsys)
    assert code == 0 and 'read: imu 20, set_pose 1' in text
    q = read_series(tmp_path / 'out', 'orientation').values
    assert quaternion.attitude_error(q[9], quaternion.exp(OMEGA * 9e-3)) < 1e-14
    expected = quaternion.multiply(target, quaternion.exp(OMEGA * 1e-3))
    assert quaternion.attitude_error(q[10], expected) < 1e-14


def test_attitude_errors_compare_at_the_sparser_stamps_with_slerp():
    omega = np.array([0.0, 0.0, 2.0])
    dense_ns = np.arange(0, 1_000_000_001, 1_000_000, dtype=np.int64)
    sparse_ns = np.arange(0, 1_000_000_001, 20_000_000, dtype=np.int64)
    dense = quaternion.exp(np.multiply.outer(dense_ns * 1e-9, omega))
    sparse = quaternion.exp(np.multiply.outer(sparse_ns * 1e-9, omega))
    # Sparse outputs against a dense truth: compared at the 51 output stamps, exactly.
    errors = attitude_errors(sparse_ns, sparse, dense_ns, dense)
    assert errors.count == 51 and errors.errors.max() < 1e-15
    # Dense outputs against a sparse truth: at the 51 truth stamps.
    errors = attitude_errors(dense_ns, dense, sparse_ns, sparse)
    assert errors.count == 51 and errors.errors.max() < 1e-15
    # Between samples slerp follows a constant-axis rotation exactly (to round-off).
    shifted_ns = sparse_ns[:-1:2] + 7_000_000
    errors = attitude_errors(sparse_ns, sparse, shifted_ns,
                             quaternion.exp(np.multiply.outer(shifted_ns * 1e-9, omega)))
    assert errors.count == 25 and errors.errors.max() < 1e-14
    assert np.array_equal(errors.stamps_ns, shifted_ns)


def test_outputs_option_selects_topics(tmp_path, capsys):
    bag = constant_rate_bag(tmp_path / 'in', imu_topic=None,
                            angular_velocity_topic='angular_velocity')
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE,
                         '--outputs', 'orientation,/diagnostics'], capsys)
    assert code == 0 and 'read: angular_velocity 200' in text
    with BagReader(tmp_path / 'out') as reader:
        assert set(reader.topics) == {'orientation', '/diagnostics'}
    # Vector3Stamped input: no imu/data to publish.
    code, _, err = run([str(bag), '-o', str(tmp_path / 'out2'), '--scene', GYRO_SCENE,
                        '--outputs', 'imu/data'], capsys)
    assert code == 1 and "error: Output 'imu/data' is not published" in err
    assert not (tmp_path / 'out2').exists()


def test_diagnostics_report_the_counts(tmp_path, capsys):
    stamps = 1.0 + np.arange(2500) / RATE
    rates = np.tile(OMEGA, (2500, 1))
    rates[1700] = np.inf
    bag = tmp_path / 'in'
    write_bag(bag, stamps=stamps, rates=rates, validate=False)
    assert run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE], capsys)[0] == 0
    with BagReader(tmp_path / 'out') as reader:
        arrays = [deserialize(data, 'diagnostic_msgs/msg/DiagnosticArray')
                  for _, _, _, data in reader.messages(['/diagnostics'])]
    # Every second of bag time from the first message (2.0 s, 3.0 s), and the next one after
    # the end (4.0 s), as a node running on would publish it.
    assert [a.header.stamp.sec for a in arrays] == [2, 3, 4]
    values = [{kv.key: kv.value for kv in a.status[0].values} for a in arrays]
    assert [v['accepted'] for v in values] == ['1000', '1999', '2499']
    assert [v['rejected non_finite'] for v in values] == ['0', '1', '1']
    assert arrays[1].status[0].level == 1 and 'non_finite' in arrays[1].status[0].message
    assert arrays[0].status[0].name == '/attitude_propagator'


def test_default_scene_notes_ignored_gyro_data(tmp_path, capsys):
    bag = constant_rate_bag(tmp_path / 'in')
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out')], capsys)
    assert code == 0
    assert "scene 'torque_free_box' (dynamics" in text
    assert 'note: the bag has gyro data but the default scene' in text
    assert '--scene strapdown' in text


def test_default_output_path_is_beside_the_input(tmp_path, capsys):
    bag = constant_rate_bag(tmp_path / 'recording', storage='mcap')
    assert run([str(bag), '--scene', GYRO_SCENE], capsys)[0] == 0
    assert (tmp_path / 'recording_replayed' / 'metadata.yaml').is_file()


@pytest.mark.parametrize('arguments, message', [
    (['{missing}'], "error: Expected a rosbag2 bag .* it does not exist"),
    (['{bag}', '--gyro-topic', 'nope'],
     "error: Gyro topic 'nope' is not in bag .*; the bag has: ground_truth "
     r"\(geometry_msgs/msg/QuaternionStamped\), imu \(sensor_msgs/msg/Imu\)"),
    (['{bag}', '--gyro-topic', 'ground_truth'],
     "error: Topic 'ground_truth' in bag .* has type 'geometry_msgs/msg/QuaternionStamped'; "
     "expected one of"),
    (['{bag}', '--ground-truth', 'imu'], "error: Topic 'imu' .* expected one of"),
    (['{bag}', '--torque-topic', 'wrench'], "error: Command topic 'wrench' is not in bag"),
    (['{bag}', '--publish-rate', '0'],
     r"error: Expected parameter `publish_rate` to be a finite number in \(0, 1000\], got 0\.0"),
    (['{bag}', '--max-angular-rate', 'nan'],
     "error: Expected parameter `max_angular_rate` to be a finite number"),
    (['{bag}', '--world-frame', 'base_link'],
     "error: Expected `world_frame` and `body_frame` to differ"),
    (['{bag}', '--scene', 'no_such_scene'], "error: Unknown scene 'no_such_scene'"),
    (['{bag}', '--integrator', 'nope'], "error: Unknown strapdown method 'nope'"),
    (['{bag}', '--start-from-ground-truth', '1.0'],
     'error: Expected a ground-truth topic with `start_from_ground_truth`'),
    (['{bag}', '--ground-truth', 'ground_truth', '--start-from-ground-truth', '99'],
     r'error: Expected an output at or after stamp 99\.000000000 s to start from the ground '
     r'truth; the last is at 10\.199000000 s'),
    (['{bag}', '-o', '{bag}'], "error: Output bag .* already exists"),
])
def test_main_reports_user_errors_without_traceback(tmp_path, capsys, arguments, message):
    bag = constant_rate_bag(tmp_path / 'in')
    argv = [a.format(bag=bag, missing=tmp_path / 'missing') for a in arguments]
    if '-o' not in argv:
        argv += ['-o', str(tmp_path / 'out')]
    if '--scene' not in argv:
        argv += ['--scene', GYRO_SCENE]
    code, _, err = run(argv, capsys)
    assert code == 1
    assert len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert not (tmp_path / 'out').exists()


def test_unknown_storage_and_corrupt_bags_are_errors(tmp_path, capsys):
    bag = constant_rate_bag(tmp_path / 'in')
    metadata = bag / 'metadata.yaml'
    metadata.write_text(metadata.read_text().replace('storage_identifier: sqlite3',
                                                     'storage_identifier: foo'))
    code, _, err = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE], capsys)
    assert code == 1 and err.startswith('error: Cannot read bag') and 'foo' in err
    with pytest.raises(SystemExit) as exit_info:
        main([str(bag), '--storage', 'foo'])
    assert exit_info.value.code == 2
    assert "invalid choice: 'foo'" in capsys.readouterr().err


def test_replay_bag_raises_the_project_errors(tmp_path):
    bag = constant_rate_bag(tmp_path / 'in')
    with pytest.raises(BagError, match="Gyro topic 'x' is not in bag"):
        replay_bag(bag, tmp_path / 'out', ReplayOptions(scene=GYRO_SCENE, gyro_topic='x'))
    with pytest.raises(InputError, match='Unknown output topic'):
        replay_bag(bag, tmp_path / 'out', ReplayOptions(scene=GYRO_SCENE, outputs=('x',)))
    with pytest.raises(SceneError):
        replay_bag(bag, tmp_path / 'out', ReplayOptions(scene=str(tmp_path / 'none.yaml')))
    assert not (tmp_path / 'out').exists()
    # Ground truth lost for the first 50 samples: nothing to start from at 10.0 s.
    stamps = 10.0 + np.arange(100) / RATE
    truth = np.tile([1.0, 0.0, 0.0, 0.0], (100, 1))
    truth[:50] = np.nan
    lost = tmp_path / 'lost'
    write_bag(lost, stamps=stamps, rates=np.tile(OMEGA, (100, 1)), ground_truth=truth)
    with pytest.raises(InputError, match=r'Expected ground truth at stamp 10\.000000000 s to '
                                         r'start from, but it covers \[10\.050000000, '):
        replay_bag(lost, tmp_path / 'out', ReplayOptions(
            scene=GYRO_SCENE, ground_truth_topic='ground_truth', start_from_ground_truth=10.0))
    assert not (tmp_path / 'out').exists()


def test_progress_bar_on_request(tmp_path, capsys):
    bag = constant_rate_bag(tmp_path / 'in')
    assert main([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE,
                 '--progress']) == 0
    assert 'msg' in capsys.readouterr().err


def test_ground_truth_types_are_read(tmp_path):
    for kind, msgtype in (('QuaternionStamped', QUATERNION_STAMPED),
                          ('PoseStamped', POSE_STAMPED)):
        bag = constant_rate_bag(tmp_path / kind, ground_truth_type=kind)
        with BagReader(bag) as reader:
            assert reader.topics['ground_truth'] == msgtype
        result = replay_bag(bag, tmp_path / f'out_{kind}',
                            ReplayOptions(scene=GYRO_SCENE, ground_truth_topic='ground_truth'))
        assert result.errors.count == 200 and result.errors.errors.max() < 1e-13


def test_stamps_within_the_first_second_are_valid(tmp_path, capsys):
    # Simulators start their clock at 0: sec 0 with nanosec > 0 is a valid stamp; only the
    # all-zero stamp means "unstamped" and is refused (zero_stamp).
    bag = constant_rate_bag(tmp_path / 'in', count=20, start=0.0)
    code, text, _ = run([str(bag), '-o', str(tmp_path / 'out'), '--scene', GYRO_SCENE],
                        capsys)
    assert code == 0 and 'used: 19; rejected: zero_stamp 1' in text
    series = read_series(tmp_path / 'out', 'orientation')
    assert series.stamps == pytest.approx(np.arange(1, 20) / RATE, abs=1e-9)
    assert quaternion.attitude_error(series.values[-1], quaternion.exp(OMEGA * 18e-3)) < 1e-14
