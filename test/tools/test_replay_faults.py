"""Tests of rigid_body_attitude.tools.replay on hostile bags: malformed and absurd messages
are rejected and counted by the session, as the node does, and the replay goes on.

The bags are real rosbag2 files written record by record with the bag writer
(:func:`bag_fixtures.write_records`), so they can hold bytes no ROS publisher would send.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bag_fixtures import build_case, write_records, write_scene
from rigid_body_attitude.bag import BagReader, deserialize, read_series
from rigid_body_attitude.msgs import (
    IMU, POSE_STAMPED, WRENCH_STAMPED, encode_imu, encode_pose_stamped, encode_wrench_stamped)
from rigid_body_attitude.tools.replay import main
from rigid_body_attitude.tools.replay.cli import parser
from rigid_body_attitude.tools.replay.options import NODE_PARAMETERS

OMEGA = (0.4, -1.1, 2.3)
START_NS = 10_000_000_000
PERIOD_NS = 1_000_000  # 1 kHz
#: Not a valid Imu: cut short, a header only, an unknown CDR encapsulation.
TRUNCATED = 50
HEADER_ONLY = 150
BAD_ENCAPSULATION = 200
#: A rate of 1e200 rad/s (above max_angular_rate), a valid message.
ABSURD_RATE = 100


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv + ['--no-progress'])
    captured = capsys.readouterr()
    assert 'Traceback' not in captured.err and 'error:' not in captured.err
    return code, captured.out, captured.err


def imu_records(count: int, faults: bool) -> list[tuple[str, int, bytes]]:
    """Imu samples of OMEGA at 1 kHz; with ``faults`` four are broken (see above)."""
    records = []
    for index in range(count):
        stamp_ns = START_NS + index * PERIOD_NS
        data = encode_imu(stamp_ns, 'base_link', OMEGA)
        if faults and index == TRUNCATED:
            data = data[:-9]
        elif faults and index == HEADER_ONLY:
            data = data[:20]
        elif faults and index == BAD_ENCAPSULATION:
            data = b'\x07\x07' + data[2:]
        elif faults and index == ABSURD_RATE:
            data = encode_imu(stamp_ns, 'base_link', (1e200, 0.0, 0.0))
        records.append(('imu', stamp_ns, data))
    return records


def test_malformed_and_absurd_gyro_messages_are_rejected_and_the_replay_goes_on(
        tmp_path, capsys):
    faulty, clean = tmp_path / 'faulty', tmp_path / 'clean'
    records = imu_records(300, faults=True)
    bad = {TRUNCATED, HEADER_ONLY, BAD_ENCAPSULATION, ABSURD_RATE}
    write_records(faulty, {'imu': IMU}, records)
    write_records(clean, {'imu': IMU}, [r for i, r in enumerate(imu_records(300, False))
                                        if i not in bad])
    code, text, err = run([str(faulty), '-o', str(tmp_path / 'out'), '--scene', 'strapdown'],
                          capsys)
    assert code == 0
    assert 'read: imu 300' in text
    assert 'used: 296; rejected: malformed 3 (imu 3), out_of_range 1' in text
    assert 'imu: malformed message rejected (malformed sensor_msgs/msg/Imu: truncated' in err
    assert 'gyro: a rate above max_angular_rate' in err
    assert run([str(clean), '-o', str(tmp_path / 'reference'), '--scene', 'strapdown'],
               capsys)[0] == 0
    # Exactly the outputs of the bag without the bad messages: a rejected message leaves no
    # trace (the next sample integrates from the last good one, as in the clean bag).
    replayed = read_series(tmp_path / 'out', 'orientation')
    reference = read_series(tmp_path / 'reference', 'orientation')
    assert replayed.stamps.size == 296
    assert np.array_equal(replayed.stamps, reference.stamps)
    assert np.array_equal(replayed.values, reference.values)
    with BagReader(tmp_path / 'out') as reader:
        last = [deserialize(data, 'diagnostic_msgs/msg/DiagnosticArray')
                for _, _, _, data in reader.messages(['/diagnostics'])][-1]
    values = {kv.key: kv.value for kv in last.status[0].values}
    assert values['malformed imu'] == '3' and values['rejected malformed'] == '3'
    assert values['rejected out_of_range'] == '1' and values['accepted'] == '296'


def command_records(faults: bool) -> list[tuple[str, int, bytes]]:
    """The constant-torque case's commands (20 Hz, held 0.5 s); with ``faults`` four bad
    messages between them: a truncated wrench, a torque of 1e308 N m, a NaN torque and a
    truncated set_pose."""
    case = build_case('constant_torque')
    records = []
    for stamp, torque in zip(case.stamps.tolist(), case.torques.tolist()):
        stamp_ns = round(stamp * 1e9)
        records.append(('torque', stamp_ns, encode_wrench_stamped(stamp_ns, 'base_link',
                                                                  (0.0, 0.0, 0.0), torque)))
    if faults:
        at = records[10][1] + 7_000_000
        good = records[10][2]
        records[11:11] = [
            ('torque', at, good[:-5]),
            ('torque', at + 1, encode_wrench_stamped(at + 1, 'base_link', (0.0, 0.0, 0.0),
                                                     (0.0, 0.0, 1e308))),
            ('torque', at + 2, encode_wrench_stamped(at + 2, 'base_link', (0.0, 0.0, 0.0),
                                                     (math.nan, 0.0, 0.0))),
            ('set_pose', at + 3, encode_pose_stamped(at + 3, 'world', (0.0, 0.0, 0.0),
                                                     (1.0, 0.0, 0.0, 0.0))[:30]),
        ]
    return records


def test_malformed_and_absurd_commands_are_rejected_and_the_replay_goes_on(tmp_path,
                                                                           capsys):
    scene = write_scene(build_case('constant_torque'), tmp_path)
    topics = {'torque': WRENCH_STAMPED, 'set_pose': POSE_STAMPED}
    for name, faults in (('faulty', True), ('clean', False)):
        write_records(tmp_path / name, topics, command_records(faults))
    code, text, err = run([str(tmp_path / 'faulty'), '-o', str(tmp_path / 'out'), '--scene',
                           str(scene)], capsys)
    assert code == 0
    assert 'read: set_pose 1, torque 43' in text
    assert ('used: 40; clock ticks: 98; rejected: malformed 2 (set_pose 1, torque 1), '
            'non_finite 1, out_of_range 1') in text
    assert 'torque: a value beyond 1e12 (N, N m); message ignored' in err
    assert run([str(tmp_path / 'clean'), '-o', str(tmp_path / 'reference'), '--scene',
                str(scene)], capsys)[0] == 0
    # The torque is constant and held 0.5 s: the rejected messages change no output.
    for topic in ('orientation', 'twist'):
        replayed = read_series(tmp_path / 'out', topic)
        reference = read_series(tmp_path / 'reference', topic)
        assert np.array_equal(replayed.stamps, reference.stamps)
        assert np.array_equal(replayed.values, reference.values)


def test_replay_runs_on_bag_time_so_it_is_deterministic(tmp_path, capsys):
    scene = write_scene(build_case('constant_torque'), tmp_path)
    write_records(tmp_path / 'in', {'torque': WRENCH_STAMPED}, command_records(False))
    for out in ('first', 'second'):
        assert run([str(tmp_path / 'in'), '-o', str(tmp_path / out), '--scene', str(scene)],
                   capsys)[0] == 0
    with BagReader(tmp_path / 'first') as first, BagReader(tmp_path / 'second') as second:
        topics = list(first.topics)
        assert list(first.messages(topics)) == list(second.messages(topics))
        arrays = [deserialize(data, 'diagnostic_msgs/msg/DiagnosticArray')
                  for _, _, _, data in first.messages(['/diagnostics'])]
    # The session's monotonic clock is the bag time: no work is timed, the clock is never
    # ahead of the propagated time.
    for array in arrays:
        values = {kv.key: kv.value for kv in array.status[0].values}
        assert values['real_time_factor'] == 'inf' and values['lag [s]'] == '0.000000'
        assert array.status[0].level == 0, array.status[0].message


def test_warnings_are_throttled_on_bag_time(tmp_path, capsys):
    # 12 s at 100 Hz, every sample above --max-angular-rate: one warning per 5 s of bag time.
    records = [('imu', START_NS + i * 10_000_000, encode_imu(START_NS + i * 10_000_000,
                                                             'base_link', OMEGA))
               for i in range(1200)]
    write_records(tmp_path / 'in', {'imu': IMU}, records)
    code, text, err = run([str(tmp_path / 'in'), '-o', str(tmp_path / 'out'), '--scene',
                           'strapdown', '--max-angular-rate', '2.0'], capsys)
    assert code == 0 and 'used: 0; rejected: out_of_range 1200' in text
    lines = [line for line in err.splitlines() if 'max_angular_rate' in line]
    assert [line.split(' s:')[0] for line in lines] == [
        '[WARN] bag time 10.000', '[WARN] bag time 15.000', '[WARN] bag time 20.000']
    assert 'logged: 3 warnings, 0 errors' in text


def test_command_line_options_are_derived_from_the_parameter_table(tmp_path, capsys):
    text = parser().format_help()
    for parameter in NODE_PARAMETERS:
        option = '--' + parameter.name.replace('_', '-')
        assert option in text, option
    assert '--publish-tf' not in text  # a bag has no TF to publish to
    assert '--no-header-stamps' in text and '--no-use-header-stamps' in text
    args = parser().parse_args(['bag', '--max-dt', '0.5', '--no-header-stamps'])
    assert args.max_dt == 0.5 and args.use_header_stamps is False
    assert parser().parse_args(['bag']).use_header_stamps is None  # the table's default


def test_double_array_options_and_a_bad_calibration_file(tmp_path, capsys):
    """``--mount-rpy`` takes numbers separated by commas; a calibration file the session
    cannot use is one ``error:`` line naming the key, and no output bag is left."""
    args = parser().parse_args(['bag', '--mount-rpy', '[0.1, -0.2, 1.5]'])
    assert args.mount_rpy == (0.1, -0.2, 1.5)
    assert parser().parse_args(['bag', '--mount-rpy', '[]']).mount_rpy == ()
    bag = tmp_path / 'input'
    write_records(bag, {'imu': IMU}, imu_records(20, faults=False))
    calibration = tmp_path / 'imu.yaml'
    calibration.write_text('scale: [1.0, 1.0]\n')
    output = tmp_path / 'out'
    for options, expected in (
            (['--calibration-file', str(calibration)],
             f"error: Calibration file '{calibration}': Expected scale to be"),
            (['--mount-rpy', '1.0,2.0'],
             'error: Expected parameter `mount_rpy` to be a double array of 3 numbers')):
        assert main([str(bag), '-o', str(output), '--scene', 'strapdown', '--no-progress',
                     *options]) == 1
        err = capsys.readouterr().err
        assert err.startswith(expected) and err.count('\n') == 1, err
        assert not output.exists()


def test_the_replay_prints_the_calibration_it_applies(tmp_path, capsys):
    """The node's start-up line, on stderr: file, kind, terms with values, noise figures."""
    bag = tmp_path / 'input'
    write_records(bag, {'imu': IMU}, imu_records(20, faults=False))
    calibration = tmp_path / 'imu.yaml'
    calibration.write_text('bias: [0.01, 0.0, 0.0]\nscale: [1.01, 1.0, 1.0]\n'
                           'gyroscope_noise_density: 2.0e-4\ngyroscope_random_walk: 3.0e-5\n')
    assert main([str(bag), '-o', str(tmp_path / 'out'), '--scene', 'strapdown',
                 '--no-progress', '--calibration-file', str(calibration)]) == 0
    lines = [line for line in capsys.readouterr().err.splitlines()
             if line.startswith('calibration: ')]
    assert lines == [f"calibration: file '{calibration}' (plain bias-scale-misalignment): "
                     'gyro_bias [rad/s] [0.01, 0, 0]; gyro_matrix K [[1.01, 0, 0], [0, 1, 0], '
                     '[0, 0, 1]]; gyroscope_noise_density [rad/s/sqrt(Hz)] 0.0002; '
                     'gyroscope_random_walk [rad/s^2/sqrt(Hz)] 3e-05']
