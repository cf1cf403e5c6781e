"""Tests of the accuracy study (rigid_body_attitude/tools/study/), mostly on its --quick set."""

import csv
import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects.base import Effect
from rigid_body_attitude.tools import study
from rigid_body_attitude.tools.study import dynamics_cases, figure, report
from rigid_body_attitude.tools.study.runner import Row


@pytest.fixture(scope='module')
def quick_output(tmp_path_factory):
    """Run the quick study once on three cases (a few seconds)."""
    output = tmp_path_factory.mktemp('study')
    code = study.main(['--quick', '--cases', 'torque_free,commanded_torque,gimbal',
                       '--output', str(output), '--no-progress'])
    return code, output


def read_rows(output):
    """The CSV rows as dictionaries."""
    with (output / 'results.csv').open() as handle:
        return list(csv.DictReader(handle))


def test_main_writes_csv_markdown_and_figure(quick_output):
    code, output = quick_output
    assert code == 0
    rows = read_rows(output)
    assert {row['case'] for row in rows} == {'torque_free', 'commanded_torque', 'gimbal'}
    assert all(float(row['cpu_s']) > 0.0 for row in rows)
    markdown = (output / 'README.md').read_text()
    # The Markdown leads with the "which method" table, one row per situation present.
    assert markdown.split('\n')[2] == '## Which method should I use'
    assert '| torque-free triaxial body (`torque_free`) | `' in markdown
    assert '| scipy DOP853 |' in markdown
    assert 'positive means the computed attitude lags' in markdown
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
    # The commanded torque switches every 0.1 s; methods with negative substeps keep their
    # order only if the command in force inside the step is pinned (as the propagator does).
    for method, order in (('rk4', 4), ('yoshida4', 4)):
        measured = math.log(error('commanded_torque', method, 100)
                            / error('commanded_torque', method, 400)) / math.log(4.0)
        assert abs(measured - order) <= 0.3, (method, measured)
    # The exact step is at round-off; the splitting keeps world momentum to round-off.
    assert error('torque_free', 'exact', 1) <= 1e-13
    strang_drift = [float(r['invariant_drift']) for r in rows
                    if r['case'] == 'torque_free' and r['method'] == 'strang']
    assert max(strang_drift) <= 1e-13


def test_main_steps_the_propagator_at_100_hz(quick_output):
    _, output = quick_output
    stepped = {r['method']: r for r in read_rows(output) if r['family'] == 'stepped'}
    names = ('exact', 'casimir8', 'rk4')
    assert set(stepped) == {f'{name} (propagator, 100 Hz)' for name in names}
    assert all(int(r['steps']) == 1000 for r in stepped.values())  # 10 s at 100 Hz
    assert float(stepped['exact (propagator, 100 Hz)']['error_rad']) <= 1e-12


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


def row(method, error, cpu, floor=0.0, case='c'):
    """A measurement over one simulated second."""
    return Row(case, method, 'dynamics', 0.1, 10, error, cpu, 1.0, floor=floor)


def test_cpu_at_error_interpolates_log_log():
    rows = [row('m', 1e-6, 0.001), row('m', 1e-10, 0.01)]
    # 1e−8 is halfway in log error between the two points, hence halfway in log CPU.
    assert study.cpu_at_error(rows, 1e-8) == pytest.approx(math.sqrt(0.001 * 0.01))
    assert math.isnan(study.cpu_at_error(rows, 1e-12))


def test_cpu_at_error_counts_unresolved_errors_as_the_floor():
    rows = [row('m', 1e-15, 0.002, floor=1e-11)]
    assert study.cpu_at_error(rows, 1e-9) == 0.002
    assert math.isnan(study.cpu_at_error(rows, 1e-12))  # below what the reference resolves


def test_cheapest_picks_the_lowest_cost_and_marks_bounds():
    rows = [row('slow', 1e-6, 0.01), row('slow', 1e-10, 0.1),
            row('fast', 1e-7, 0.002), row('fast', 1e-11, 0.02)]
    choice = study.cheapest(rows, 'c', ('dynamics',), 1e-9)
    assert choice.method == 'fast' and choice.cost == pytest.approx(0.002 * 10 ** 0.5)
    assert not choice.bound
    # 1e−4 is reached by fast's cheapest run: its cost is only an upper bound.
    assert study.cheapest(rows, 'c', ('dynamics',), 1e-4) == report.Choice('fast', 0.002, True)
    assert study.cheapest(rows, 'c', ('dynamics',), 1e-13) is None


def test_dynamics_cases_integrate_the_scene_effects():
    # No torque is re-derived in the study: every torque the methods integrate is a bound
    # method of an effect the scene built (and scipy evaluates the same model).
    for name, make_case in dynamics_cases.DYNAMICS_CASES.items():
        propagator = make_case(True).propagator()
        for torque in propagator.model.torque_functions:
            assert isinstance(torque.__self__, Effect), name
            assert torque.__self__ in propagator.effects, name
    top = dynamics_cases.heavy_top_case(True).propagator()
    assert [e.name for e in top.effects] == ['gravity_about_pivot']
    state = np.concatenate([quat.normalize([0.7, 0.2, -0.4, 0.3]), [0.1, 0.2, 25.0]])
    rhs = dynamics_cases.model_rhs(top.model)(0.0, state)
    assert np.array_equal(rhs[4:], top.model.omega_dot(0.0, state[:4], state[4:]))


def test_method_styles_distinct_within_a_panel():
    methods = [f'm{k}' for k in range(len(figure.MARKERS))]
    styles = figure.method_styles(methods)
    assert len({colour for colour, _ in styles.values()}) == len(methods)
    assert len({marker for _, marker in styles.values()}) == len(methods)
    with pytest.raises(ValueError, match='Expected at most 24 methods in a panel, got 25'):
        figure.method_styles(methods + ['one more'])
