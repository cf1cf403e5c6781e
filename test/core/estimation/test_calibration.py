"""IMU calibration files: worked examples computed by hand, and hostile files refused."""

from __future__ import annotations

import math
from pathlib import Path
import re
import warnings

import numpy as np
import pytest

from rigid_body_attitude.core.estimation.calibration import (
    calibration_from_mapping, calibration_noise, calibration_terms, ImuCalibration,
    load_calibration)
from rigid_body_attitude.core.errors import CalibrationError
from rigid_body_attitude.core.yaml_files import MAX_ERROR_CHARS, MAX_FILE_BYTES

# kalibr imu-camera result, worked by hand (kalibr's model, IccScaledMisalignedImu):
#   w_measured = M C w_i + A C a_i + b,   a_measured = M_a a_i
#   M   = [[1.25, 0, 0], [0.05, 1, 0], [0, 0, 0.8]]   (lower triangular)
#   M⁻¹ = [[0.8, 0, 0], [-0.04, 1, 0], [0, 0, 1.25]]   (check: row 2 of M times column 1
#         of M⁻¹ is 0.05·0.8 + 1·(−0.04) = 0)
#   C   = 90° about z = [[0, -1, 0], [1, 0, 0], [0, 0, 1]];  Cᵀ = [[0, 1, 0], [-1, 0, 0],
#         [0, 0, 1]]
#   A   = diag(0.01, 0, 0.02),  M_a = diag(1, 1, 2)
# Sample: a_measured = (0, 0, 20) → a_i = M_a⁻¹ a_measured = (0, 0, 10)
#         C a_i = (0, 0, 10);  A C a_i = (0, 0, 0.2)
#         w_measured = (1, 2, 3) → w_measured − A C a_i = (1, 2, 2.8)
#         M⁻¹ (1, 2, 2.8) = (0.8, −0.04 + 2, 3.5) = (0.8, 1.96, 3.5)
#         Cᵀ (0.8, 1.96, 3.5) = (1.96, −0.8, 3.5)
# Forward check: C (1.96, −0.8, 3.5) = (0.8, 1.96, 3.5); M (0.8, 1.96, 3.5) = (1, 2, 2.8);
#                plus A C a_i = (1, 2, 3).
KALIBR_RESULT = """\
imu0:
  T_i_b:
  - [1.0, 0.0, 0.0, 0.0]
  - [0.0, 1.0, 0.0, 0.0]
  - [0.0, 0.0, 1.0, 0.0]
  - [0.0, 0.0, 0.0, 1.0]
  accelerometer_noise_density: 2.0e-03
  accelerometer_random_walk: 3.0e-03
  accelerometers:
    M:
    - [1.0, 0.0, 0.0]
    - [0.0, 1.0, 0.0]
    - [0.0, 0.0, 2.0]
  gyroscope_noise_density: 1.6968e-04
  gyroscope_random_walk: 1.9393e-05
  gyroscopes:
    A:
    - [0.01, 0.0, 0.0]
    - [0.0, 0.0, 0.0]
    - [0.0, 0.0, 0.02]
    C_gyro_i:
    - [0.0, -1.0, 0.0]
    - [1.0, 0.0, 0.0]
    - [0.0, 0.0, 1.0]
    M:
    - [1.25, 0.0, 0.0]
    - [0.05, 1.0, 0.0]
    - [0.0, 0.0, 0.8]
  model: scale-misalignment
  rostopic: /imu0
  time_offset: 0.0
  update_rate: 200.0
"""
HAND_RATE = (1.96, -0.8, 3.5)
HAND_ACC = (0.0, 0.0, 10.0)

# EuRoC's ADIS16448 noise model as kalibr's imu.yaml, with OpenVINS's first line.
KALIBR_IMU_YAML = """\
%YAML:1.0
rostopic: /imu0
update_rate: 200.0
gyroscope_noise_density: 1.6968e-04
gyroscope_random_walk: 1.9393e-05
accelerometer_noise_density: 2.0000e-03
accelerometer_random_walk: 3.0000e-03
"""

# Plain file (imu_tk's X' = T K (X − B)), by hand:
#   raw (1.1, 1.2, 2.3) − bias (0.1, 0.2, 0.3) = (1, 1, 2)
#   K = diag(2, 1, 0.5): (2, 1, 1);  T = [[1, 0, 0], [0.1, 1, 0], [0, 0, 1]]: (2, 1.2, 1)
PLAIN = """\
bias: [0.1, 0.2, 0.3]
scale: [2.0, 1.0, 0.5]
misalignment:
- [1.0, 0.0, 0.0]
- [0.1, 1.0, 0.0]
- [0.0, 0.0, 1.0]
"""


def _write(tmp_path: Path, text: str | bytes, name: str = 'imu.yaml') -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


def test_load_calibration_kalibr_result_matches_the_hand_worked_sample(tmp_path):
    calibration = load_calibration(_write(tmp_path, KALIBR_RESULT))
    assert calibration.kind == 'kalibr'
    rate, acc = calibration.correct(1.0, 2.0, 3.0, 0.0, 0.0, 20.0)
    assert rate == pytest.approx(HAND_RATE, abs=1e-12)
    assert acc == pytest.approx(HAND_ACC, abs=1e-12)
    assert calibration.uses_accelerometer
    rates, accs = calibration.correct_rows(np.array([[1.0, 2.0, 3.0]] * 2),
                                           np.array([[0.0, 0.0, 20.0]] * 2))
    np.testing.assert_allclose(rates, [HAND_RATE] * 2, atol=1e-12)
    np.testing.assert_allclose(accs, [HAND_ACC] * 2, atol=1e-12)
    assert calibration.noise.update_rate == 200.0
    assert calibration.noise.rostopic == '/imu0'


def test_load_calibration_kalibr_imu_yaml_skips_the_yaml_directive_line(tmp_path):
    calibration = load_calibration(_write(tmp_path, KALIBR_IMU_YAML))
    assert calibration.kind == 'kalibr_noise'
    assert calibration.noise.gyroscope_noise_density == 1.6968e-04
    assert calibration.noise.gyroscope_random_walk == 1.9393e-05
    assert calibration.noise.accelerometer_random_walk == 3.0e-03
    # Discrete sigma per sample = density · √rate: 1.6968e-4 · 14.142135... = 2.39964e-3.
    assert calibration.noise.gyro_sigma() == pytest.approx(2.39964e-3, rel=1e-5)
    assert calibration.noise.accelerometer_sigma() == pytest.approx(2.828427e-2, rel=1e-6)
    # No intrinsics: every sample passes unchanged.
    assert calibration.correct(0.1, -0.2, 0.3, 1.0, 2.0, 9.0) == ((0.1, -0.2, 0.3),
                                                                  (1.0, 2.0, 9.0))


def test_load_calibration_plain_file_matches_the_hand_worked_sample(tmp_path):
    calibration = load_calibration(_write(tmp_path, PLAIN))
    assert calibration.kind == 'plain'
    assert calibration.correct_gyro(1.1, 1.2, 2.3) == pytest.approx((2.0, 1.2, 1.0), abs=1e-12)
    assert not calibration.uses_accelerometer


def test_calibration_from_mapping_picks_the_named_imu():
    second = {'gyroscopes': {'M': [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]}}
    data = {'imu0': {'update_rate': 100.0}, 'imu1': second}
    calibration = calibration_from_mapping(data, imu_key='imu1')
    assert calibration.correct_gyro(2.0, 4.0, 6.0) == pytest.approx((1.0, 2.0, 3.0))
    with pytest.raises(CalibrationError, match='several IMUs'):
        calibration_from_mapping(data)


def test_imu_calibration_identity_by_default():
    corrected = ImuCalibration().correct(1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert corrected == ((1.0, 2.0, 3.0), (4.0, 5.0, 6.0))


def _refused(tmp_path: Path, text: str | bytes, pattern: str, imu_key: str = '') -> str:
    path = _write(tmp_path, text)
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        with pytest.raises(CalibrationError) as caught:
            load_calibration(path, imu_key=imu_key)
    message = str(caught.value)
    assert message.startswith(f'Calibration file {str(path)!r}'), message
    assert '\n' not in message and len(message) <= MAX_ERROR_CHARS, message
    assert re.search(pattern, message), message
    return message


def _replace(old: str, new: str) -> str:
    assert old in KALIBR_RESULT
    return KALIBR_RESULT.replace(old, new, 1)


def test_load_calibration_refuses_a_missing_imu_key(tmp_path):
    _refused(tmp_path, KALIBR_RESULT, r"Missing key 'imu1'.*imu0", imu_key='imu1')


def test_load_calibration_refuses_a_matrix_of_the_wrong_shape(tmp_path):
    text = _replace('    - [0.0, 0.0, 0.8]\n', '')
    _refused(tmp_path, text, r'imu0\.gyroscopes\.M.*3x3 matrix')
    _refused(tmp_path, _replace('[1.25, 0.0, 0.0]', '[1.25, 0.0]'),
             r'imu0\.gyroscopes\.M.*3x3 matrix')
    _refused(tmp_path, 'bias: [0.1, 0.2]\n', r'bias.*3 numbers')


def test_load_calibration_refuses_non_finite_numbers(tmp_path):
    _refused(tmp_path, _replace('[0.01, 0.0, 0.0]', '[.nan, 0.0, 0.0]'),
             r'imu0\.gyroscopes\.A.*finite')
    _refused(tmp_path, 'bias: [.inf, 0.0, 0.0]\n', r'bias.*finite')
    _refused(tmp_path, _replace('update_rate: 200.0', 'update_rate: -200.0'),
             r'imu0\.update_rate.*\[1, 100000\]')
    _refused(tmp_path, KALIBR_IMU_YAML.replace('1.6968e-04', '1e-4'),
             r'gyroscope_noise_density.*YAML 1\.1')


def test_load_calibration_refuses_a_singular_matrix(tmp_path):
    """A singular matrix has a scale factor far from 1 (the bounds keep every accepted
    matrix diagonally dominant, so invertible)."""
    _refused(tmp_path, _replace('[0.0, 0.0, 0.8]', '[0.0, 0.0, 0.0]'),
             r'scale factors \(diagonal\) of imu0\.gyroscopes\.M to be in \[0\.5, 2\].*\[2\]\[2\]')
    _refused(tmp_path, 'scale: [1.0, 0.0, 1.0]\n', r'scale factors .*of scale.*0\.0 at \[1\]\[1\]')


@pytest.mark.parametrize('text, pattern', [
    ('scale: [57.3, 1.0, 1.0]\n', r'scale factors \(diagonal\) of scale to be in \[0\.5, 2\], '
                                  r'got 57\.3'),
    ('misalignment: [[1, 0.3, 0], [0, 1, 0], [0, 0, 1]]\n',
     r'misalignment \(off-diagonal\) entries of misalignment to be at most 0\.1.*'
     r'0\.3 at \[0\]\[1\]'),
    ('accelerometer_matrix: [[1, 0, 0], [0, 1, 0], [0, 0, -1]]\n',
     r'accelerometer_matrix to be in \[0\.5, 2\], got -1\.0'),
    ('bias: [150.0, 0.0, 0.0]\n', r'bias to be at most 100'),
    (KALIBR_IMU_YAML.replace('1.6968e-04', '0.0'), r'gyroscope_noise_density to be in \(0, 1\]'),
    (KALIBR_IMU_YAML.replace('1.6968e-04', '5.0'), r'gyroscope_noise_density to be in \(0, 1\]'),
    (KALIBR_IMU_YAML.replace('2.0000e-03', '11.0'), r'accelerometer_noise_density .*\(0, 10\]'),
    (KALIBR_IMU_YAML.replace('200.0', '1.0e+7'), r'update_rate to be in \[1, 100000\]'),
])
def test_load_calibration_refuses_values_out_of_physical_bounds(tmp_path, text, pattern):
    _refused(tmp_path, text, pattern)


@pytest.mark.parametrize('missing', ['gyroscope_random_walk', 'gyroscope_noise_density',
                                     'update_rate'])
def test_a_kalibr_imu_yaml_missing_a_key_the_node_uses_is_refused(tmp_path, missing):
    text = ''.join(line + '\n' for line in KALIBR_IMU_YAML.splitlines()
                   if not line.startswith(missing))
    _refused(tmp_path, text, rf'Missing key {missing}')


def test_noise_figures_come_in_pairs_in_every_kind_of_file(tmp_path):
    _refused(tmp_path, _replace('  accelerometer_random_walk: 3.0e-03\n', ''),
             r'Missing key imu0\.accelerometer_random_walk \(given with '
             r'imu0\.accelerometer_noise_density')
    _refused(tmp_path, 'bias: [0.0, 0.0, 0.0]\ngyroscope_random_walk: 1e-5\n',
             r'Missing key gyroscope_noise_density')
    gyro_only = ''.join(line + '\n' for line in KALIBR_IMU_YAML.splitlines()
                        if not line.startswith('accelerometer'))
    assert load_calibration(_write(tmp_path, gyro_only)).noise.accelerometer_noise_density is None


def test_load_calibration_refuses_a_c_gyro_that_is_not_a_rotation(tmp_path):
    _refused(tmp_path, _replace('[0.0, -1.0, 0.0]', '[0.0, -1.1, 0.0]'),
             r'imu0\.gyroscopes\.C_gyro_i.*rotation matrix')
    # A reflection is orthonormal but not a rotation.
    _refused(tmp_path, _replace('[0.0, 0.0, 1.0]\n    M:', '[0.0, 0.0, -1.0]\n    M:'),
             r'C_gyro_i.*determinant')


def test_load_calibration_refuses_unknown_keys_and_non_mappings(tmp_path):
    _refused(tmp_path, 'bias: [0.0, 0.0, 0.0]\nbais: 1\n', r"Unknown key 'bais'")
    _refused(tmp_path, _replace('  model:', '  modle: x\n  model:'),
             r"Unknown key 'modle' in imu0; valid keys: ")
    _refused(tmp_path, '[1, 2, 3]\n', r'Expected a mapping')
    _refused(tmp_path, 'hello: 1\n', r'Expected kalibr keys')
    _refused(tmp_path, 'imu0:\n  gyroscopes: [1, 2]\n', r'imu0\.gyroscopes.*mapping')


def test_load_calibration_refuses_what_the_scene_reader_refuses(tmp_path):
    _refused(tmp_path, b'bias: [0.0, 0.0, 0.0]\n# \xff\n', r'not UTF-8')
    _refused(tmp_path, 'a: &x [1]\nbias: *x\n', r'aliases.*calibration files')
    _refused(tmp_path, 'bias: [0.0, 0.0\n', r'not valid YAML')
    _refused(tmp_path, '#' * (MAX_FILE_BYTES + 1), r'larger than the limit')
    with pytest.raises(CalibrationError, match='does not exist'):
        load_calibration(tmp_path / 'missing.yaml')


def test_correct_gyro_rows_agree_with_samples():
    rng = np.random.default_rng(3)
    matrix = np.eye(3) + 0.01 * rng.standard_normal((3, 3))
    calibration = ImuCalibration(gyro_matrix=matrix, gyro_bias=rng.standard_normal(3) * 0.01,
                                 g_sensitivity=1e-4 * rng.standard_normal((3, 3)),
                                 accelerometer_matrix=np.eye(3) * 1.01,
                                 accelerometer_bias=np.array([0.1, 0.0, -0.1]))
    gyro, acc = rng.standard_normal((5, 3)), rng.standard_normal((5, 3)) + [0.0, 0.0, 9.8]
    rates, accs = calibration.correct_rows(gyro, acc)
    for k in range(5):
        rate, a = calibration.correct(*gyro[k].tolist(), *acc[k].tolist())
        np.testing.assert_allclose(rate, rates[k], atol=1e-14)
        np.testing.assert_allclose(a, accs[k], atol=1e-14)
    assert math.isfinite(float(rates.sum()))


# The IMU's further figures beside kalibr's noise (datasheet values of a MEMS IMU).
FIGURES_YAML = """\
accelerometer_bias_stddev: 0.196
gyroscope_turn_on_bias: 0.0175
gyroscope_scale_stddev: 0.01
gyroscope_misalignment_stddev: 0.005
accelerometer_range: 156.9
sample_timing: 0.0015
"""


def test_a_calibration_file_carries_the_filters_further_figures(tmp_path):
    calibration = load_calibration(_write(tmp_path, KALIBR_IMU_YAML + FIGURES_YAML))
    noise = calibration_noise(calibration)
    assert noise == {'gyroscope_noise_density': 1.6968e-04, 'gyroscope_random_walk': 1.9393e-05,
                     'accelerometer_noise_density': 2e-3, 'accelerometer_random_walk': 3e-3,
                     'accelerometer_bias_stddev': 0.196, 'gyroscope_turn_on_bias': 0.0175,
                     'gyroscope_scale_stddev': 0.01, 'gyroscope_misalignment_stddev': 0.005,
                     'accelerometer_range': 156.9, 'sample_timing': 0.0015}
    terms = dict(calibration_terms(calibration))
    assert terms['gyroscope_scale_stddev [1]'] == '0.01'
    assert terms['accelerometer_range [m/s^2]'] == '156.9'
    plain = load_calibration(_write(tmp_path, 'bias: [0.0, 0.0, 0.0]\nsample_timing: 0.001\n'))
    assert calibration_noise(plain) == {'sample_timing': 0.001}
    assert calibration_noise(load_calibration(_write(tmp_path, KALIBR_IMU_YAML))) == {
        'gyroscope_noise_density': 1.6968e-04, 'gyroscope_random_walk': 1.9393e-05,
        'accelerometer_noise_density': 2e-3, 'accelerometer_random_walk': 3e-3}


@pytest.mark.parametrize('line, pattern', [
    ('gyroscope_scale_stddev: 0.9\n', r'gyroscope_scale_stddev to be in \[0, 0\.5\], got 0\.9'),
    ('accelerometer_bias_stddev: -0.1\n', r'accelerometer_bias_stddev to be in \[0, 10\]'),
    ('accelerometer_range: 0.5\n', r'accelerometer_range to be in \[1, 10000\]'),
    ('sample_timing: .nan\n', r'sample_timing'),
    ('gyroscope_turn_on_bias: fast\n', r'gyroscope_turn_on_bias'),
])
def test_a_figure_out_of_its_bounds_is_one_error_line(tmp_path, line, pattern):
    message = _refused(tmp_path, KALIBR_IMU_YAML + line, pattern)
    assert '\n' not in message
