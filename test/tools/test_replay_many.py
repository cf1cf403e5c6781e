"""``replay`` over many bags (a folder of bags or a glob pattern): one Dask task per bag on a
real LocalCluster (or in this process with ``--serial``), one table; one bag as before."""

from __future__ import annotations

import csv
from pathlib import Path

from bag_fixtures import build_case, write_case_bag, write_scene
from rigid_body_attitude.bag import write_bag
from rigid_body_attitude.tools.replay.cli import is_many_bags, main
from rigid_body_attitude.tools.replay.fleet import DYNAMICS_COLUMNS


def _bags(tmp_path: Path) -> tuple[Path, Path]:
    """A folder with a bag with ground truth, one without, one broken file; the scene."""
    case = build_case('constant_rate')
    scene = write_scene(case, tmp_path)
    bags = tmp_path / 'bags'
    bags.mkdir()
    write_case_bag(case, bags / 'with_truth')
    write_bag(bags / 'no_truth', stamps=case.stamps, rates=case.rates)
    (bags / 'broken.mcap').write_bytes(b'not a bag')
    return bags, scene


def _table(path: Path) -> dict[str, dict[str, str]]:
    with path.open(newline='') as file:
        return {Path(row['bag']).name: row for row in csv.DictReader(file)}


def _header(printed: str) -> str:
    """The printed table's header line."""
    headers = [line for line in printed.splitlines() if line.startswith('| bag | status |')]
    assert len(headers) == 1, printed
    return headers[0]


def test_a_folder_of_bags_is_replayed_on_a_local_cluster_into_one_table(tmp_path, capsys):
    bags, scene = _bags(tmp_path)
    out = tmp_path / 'out'
    code = main([str(bags), '-o', str(out), '--workers', '2', '--scene', str(scene),
                 '--ground-truth', 'ground_truth', '--no-progress'])
    printed = capsys.readouterr().out
    assert code == 0 and '3 bags, 1 not replayed' in printed
    assert printed.count('| ok |') == 2 and 'broken.mcap | error |' in printed
    rows = _table(out / 'fleet.csv')
    assert sorted(rows) == ['broken.mcap', 'no_truth', 'with_truth']
    assert rows['broken.mcap']['status'] == 'error' and rows['broken.mcap']['error']
    assert rows['no_truth']['status'] == 'ok' and rows['no_truth']['truth_samples'] == '0'
    assert int(rows['with_truth']['truth_samples']) > 0
    assert float(rows['with_truth']['error_max_deg']) < 1e-6
    assert (out / 'with_truth_replayed' / 'metadata.yaml').is_file()
    assert (out / 'no_truth_replayed' / 'metadata.yaml').is_file()
    # A gyro scene simulates no body: no energy or momentum drift columns.
    header = _header(printed)
    assert 'error_max_deg' in header
    for column in DYNAMICS_COLUMNS:
        assert column not in printed and column not in rows['with_truth']


def test_a_dynamics_scene_fleet_table_has_the_drift_columns(tmp_path, capsys):
    case = build_case('torque_free')
    scene = write_scene(case, tmp_path)
    bags = tmp_path / 'bags'
    bags.mkdir()
    for name in ('first', 'second'):
        write_case_bag(case, bags / name)
    out = tmp_path / 'out'
    code = main([str(bags), '-o', str(out), '--serial', '--scene', str(scene),
                 '--ground-truth', 'ground_truth', '--no-progress'])
    printed = capsys.readouterr().out
    assert code == 0 and printed.count('| ok |') == 2
    header = _header(printed)
    assert '| energy_drift | momentum_drift |' in header, printed
    for row in _table(out / 'fleet.csv').values():
        assert abs(float(row['energy_drift'])) < 1e-9 and abs(float(row['momentum_drift'])) < 1e-9


def test_a_glob_pattern_replays_the_matching_bags_only(tmp_path, capsys):
    bags, scene = _bags(tmp_path)
    out = tmp_path / 'out'
    code = main([str(bags / '*_truth'), '-o', str(out), '--serial', '--scene', str(scene),
                 '--ground-truth', 'ground_truth', '--no-progress'])
    assert code == 0 and '2 bags, 0 not replayed' in capsys.readouterr().out
    assert sorted(_table(out / 'fleet.csv')) == ['no_truth', 'with_truth']


def test_one_bag_is_replayed_as_one_bag(tmp_path, capsys):
    bags, scene = _bags(tmp_path)
    assert not is_many_bags(str(bags / 'with_truth')) and is_many_bags(str(bags))
    assert not is_many_bags(str(bags / 'broken.mcap')) and is_many_bags(str(bags / '*'))
    code = main([str(bags / 'with_truth'), '--scene', str(scene), '--no-progress'])
    printed = capsys.readouterr().out
    assert code == 0 and 'not replayed' not in printed and '| ok |' not in printed
    assert (bags / 'with_truth_replayed' / 'metadata.yaml').is_file()
    assert not (bags / 'with_truth_replayed' / 'fleet.csv').exists()


def test_mistakes_with_many_bags_are_one_error_line(tmp_path, capsys):
    bags, _ = _bags(tmp_path)
    cases = [([str(bags / '*')], '-o/--output is required'),
             ([str(tmp_path / 'nothing*'), '-o', str(tmp_path / 'o')], 'No bag in'),
             ([str(bags), '--csv', str(tmp_path / 'x.csv')], '--csv and --plot are for one'),
             ([str(bags), '--workers', '-1'], '--workers must be at least 1')]
    for arguments, message in cases:
        assert main(arguments) == 1
        err = capsys.readouterr().err
        assert err.startswith('error: ') and message in err and err.count('\n') == 1, err
