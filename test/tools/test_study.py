"""Tests of the accuracy study CLI (rigid_body_attitude/tools/study.py), on its --quick set."""

import csv
import math

import numpy as np
import pytest

from rigid_body_attitude.core import quaternion as quat
from rigid_body_attitude.tools import study


@pytest.fixture(scope='module')
def quick_output(tmp_path_factory):
    """Run the quick study once on three cases (a few seconds)."""
    output = tmp_path_factory.mktemp('study')
    code = study.main(['--quick', '--cases', 'torque_free,heavy_top,gimbal', '--output',
                       str(output), '--no-progress'])
    return code, output


def read_rows(output):
    """The CSV rows as dictionaries."""
    with (output / 'results.csv').open() as handle:
        return list(csv.DictReader(handle))


def test_main_writes_csv_markdown_and_figure(quick_output):
    code, output = quick_output
    assert code == 0
    rows = read_rows(output)
    assert {row['case'] for row in rows} == {'torque_free', 'heavy_top', 'gimbal'}
    assert all(float(row['cpu_s']) > 0.0 for row in rows)
    markdown = (output / 'README.md').read_text()
    assert '## Heavy top: CPU time to reach 1e−9 rad' in markdown
    assert '| scipy DOP853 |' in markdown
    assert (output / 'work_precision.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_main_measures_orders_and_invariants(quick_output):
    _, output = quick_output
    rows = read_rows(output)

    def error(case, method, steps):
        return next(float(r['error_rad']) for r in rows
                    if r['case'] == case and r['method'] == method and int(r['steps']) == steps)
    # Quick torque-free sweep: 100 and 400 steps on the Hairer–Vilmart body; 4× the steps
    # divides a fourth-order error by 256 and a second-order one by 16 (±0.3 in the order).
    for method, order in (('rk4', 4), ('rkmk4', 4), ('strang', 2), ('yoshida4', 4)):
        measured = math.log(error('torque_free', method, 100)
                            / error('torque_free', method, 400)) / math.log(4.0)
        assert abs(measured - order) <= 0.3, (method, measured)
    # The exact step is at round-off; the splitting keeps world momentum to round-off.
    assert error('torque_free', 'exact', 1) <= 1e-13
    strang_drift = [float(r['invariant_drift']) for r in rows
                    if r['case'] == 'torque_free' and r['method'] == 'strang']
    assert max(strang_drift) <= 1e-13


def test_main_gimbal_case_shows_euler_angle_breakdown(quick_output):
    _, output = quick_output
    rows = [r for r in read_rows(output) if r['case'] == 'gimbal' and r['steps'] == '40']
    by_method = {r['method']: r for r in rows}
    # Passing 0.02 rad from sin θ = 0, the ZXZ rates are ~50× the body rate: the Euler-angle
    # form is far worse than RK4 on the quaternion at the same step (or refuses the step).
    euler = by_method['euler_zxz_rk4']
    quaternion_error = float(by_method['rk4_quaternion (ω(t))']['error_rad'])
    assert euler['note'].startswith('refused') or (
        float(euler['error_rad']) > 1e4 * quaternion_error)


def test_main_unknown_case_is_an_error(tmp_path, capsys):
    code = study.main(['--cases', 'coning,warp_drive', '--output', str(tmp_path)])
    assert code == 2
    assert "error: unknown case(s) ['warp_drive']" in capsys.readouterr().err


def test_cpu_at_error_interpolates_log_log():
    rows = [study.Row('c', 'm', 'f', 0.1, 10, 1e-6, 0.001, 1.0),
            study.Row('c', 'm', 'f', 0.01, 100, 1e-10, 0.01, 1.0)]
    # 1e−8 is halfway in log error between the two points, hence halfway in log CPU.
    assert study.cpu_at_error(rows, 1e-8) == pytest.approx(math.sqrt(0.001 * 0.01))
    assert math.isnan(study.cpu_at_error(rows, 1e-12))


def test_heavy_top_torque_is_gravity_about_pivot():
    attitude = quat.normalize([0.7, 0.2, -0.4, 0.3])
    force_body = quat.rotate_inverse(attitude, [0.0, 0.0, -1.0])
    expected = study.HEAVY_TOP_MGL * np.cross([0.0, 0.0, 1.0], force_body)
    np.testing.assert_allclose(study.heavy_top_torque(0.0, attitude, None), expected,
                               atol=1e-15)
