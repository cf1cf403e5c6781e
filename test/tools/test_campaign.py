"""Campaigns on a real Dask LocalCluster (worker processes): identical runs whatever the
chunking and workers, resume, a killed worker, failed runs, the CLI, fleet replay; specs
bounded by what the engine can hold, and ``--out`` left as found or resumable."""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Any, Iterator

import numpy as np
import pytest
import yaml
from distributed import Client, LocalCluster

from bag_fixtures import build_case, write_case_bag, write_scene
from rigid_body_attitude.bag import write_bag
from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.paths import config_folders
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping
from rigid_body_attitude.tools.campaign import (
    FAILURE_REASONS, load_spec, local_cluster, main, read_runs, replay_fleet, run_campaign,
    run_chunk, sample_runs, spec_from_mapping, SpecError)
from rigid_body_attitude.tools.campaign.budget import (
    budget_problem, estimate, MAX_BODY_STEPS, MAX_STEPS_PER_RUN)
from rigid_body_attitude.tools.replay import ReplayOptions

SCENE = {'name': 'box', 'rate_source': 'dynamics', 'integrator': 'rk4', 'step': 0.01,
         'body': {'mass': 1.0, 'inertia': {'moments': [1.0, 2.0, 2.5]}},
         'initial_state': {'omega_body': [0.1, 1.0, 0.05]},
         'effects': [{'viscous_damping': {'coefficient': 0.01}}]}
SPEC = {'name': 'box_campaign', 'scene': SCENE, 'runs': 60, 'seed': 11, 'duration': 1.0,
        'output_times': {'every': 0.25}, 'chunk': 16,
        'dispersions': {'inertia': {'second_moments_sigma': 0.1, 'axes': 'uniform'},
                        'attitude': 'uniform', 'omega_body': {'sigma': [0.2, 0.2, 0.2]},
                        'effects': {'viscous_damping': {'coefficient': {'uniform': [0, 0.1]}}},
                        'commands': {'sigma': [0.05, 0.05, 0.05]}},
        'commands': [{'time': 0.0, 'torque': [0.0, 0.0, 0.1]},
                     {'time': 0.5, 'torque': [0.0, 0.0, 0.0]}],
        'statistics': {'percentiles': [5, 50, 95]}}


@pytest.fixture(scope='module')
def client() -> Iterator[Client]:
    """Two single-threaded worker processes (each with its nanny)."""
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=':0', silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as dask_client:
        yield dask_client


def spec(**changes: Any) -> Any:
    return spec_from_mapping({**SPEC, **changes})


def assert_same_runs(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert sorted(a) == sorted(b)
    for name in a:
        assert a[name].dtype == b[name].dtype, name
        assert np.array_equal(a[name], b[name], equal_nan=a[name].dtype.kind == 'f'), name


def test_serial_and_a_two_worker_cluster_give_bit_identical_runs(tmp_path, client):
    serial = run_campaign(spec(), tmp_path / 'serial', serial=True)
    # Through the scheduler's address, as `campaign --scheduler ADDRESS` does.
    cluster = run_campaign(spec(chunk=7), tmp_path / 'cluster',
                           scheduler=client.scheduler.address, plot=False)
    assert serial.runs == cluster.runs == 60 and serial.failed == cluster.failed == 0
    assert cluster.chunks_run == 9
    serial_runs = read_runs(tmp_path / 'serial', spec())
    assert_same_runs(serial_runs, read_runs(tmp_path / 'cluster', spec(chunk=7)))
    # One run on its own, as when reproducing a case: the same numbers again.
    assert_same_runs({k: v[[37]] for k, v in serial_runs.items()}, run_chunk(spec(), [37]))
    for name, table in serial.statistics.items():
        assert np.array_equal(table, cluster.statistics[name], equal_nan=True), name
    files = {path.name for path in (tmp_path / 'serial').iterdir()}
    assert {'campaign.json', 'chunks', 'statistics.csv', 'summary.json',
            'summary.png'} <= files
    assert (tmp_path / 'serial' / 'summary.png').read_bytes()[:4] == b'\x89PNG'


def test_dispersions_are_applied_per_run():
    parameters = sample_runs(spec(), np.arange(60))
    assert len({tuple(q) for q in parameters.attitude.round(12)}) == 60
    assert parameters.inertia is not None and parameters.inertia.shape == (60, 3, 3)
    damping = parameters.effects['viscous_damping']['coefficient']
    assert damping.shape == (60, 3) and 0.0 <= damping.min() and damping.max() <= 0.1
    assert parameters.commands.shape == (2, 60, 3)
    assert abs(np.mean(parameters.commands[0, :, 2]) - 0.1) < 0.03
    assert np.std(parameters.commands[1, :, 0]) > 0.02


def test_an_interrupted_campaign_resumes_without_redoing_finished_chunks(tmp_path):
    first = run_campaign(spec(), tmp_path, serial=True, plot=False)
    assert first.chunks_run == 4
    complete = read_runs(tmp_path, spec())
    chunk_files = sorted((tmp_path / 'chunks').glob('*.parquet'))
    stamps = {path.name: path.stat().st_mtime_ns for path in chunk_files}
    chunk_files[2].unlink()  # as if interrupted before chunk 2 was written
    (tmp_path / 'chunks' / '00002.123.tmp').write_bytes(b'half a file')
    again = run_campaign(spec(), tmp_path, serial=True, plot=False)
    assert (again.chunks_run, again.chunks_resumed) == (1, 3)
    for path in sorted((tmp_path / 'chunks').glob('*.parquet')):
        if path.name != chunk_files[2].name:
            assert path.stat().st_mtime_ns == stamps[path.name]
    assert_same_runs(complete, read_runs(tmp_path, spec()))
    with pytest.raises(SpecError, match='another campaign'):
        run_campaign(spec(seed=12), tmp_path, serial=True, plot=False)


def test_a_worker_killed_mid_campaign_loses_and_duplicates_no_run(tmp_path, client):
    slow = spec(runs=160, chunk=20, duration=3.0)
    result: dict[str, Any] = {}
    thread = threading.Thread(target=lambda: result.update(
        done=run_campaign(slow, tmp_path / 'killed', client=client, plot=False)))
    thread.start()
    killed = False
    deadline = time.monotonic() + 60.0
    while not killed and thread.is_alive() and time.monotonic() < deadline:
        busy = [address for address, keys in client.processing().items() if keys]
        written = len(list((tmp_path / 'killed' / 'chunks').glob('*.parquet'))) \
            if (tmp_path / 'killed' / 'chunks').is_dir() else 0
        if busy and written >= 1:
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed = True
        time.sleep(0.05)
    thread.join(timeout=120.0)
    assert killed and not thread.is_alive()
    assert result['done'].runs == 160 and result['done'].chunks_run == 8
    runs = read_runs(tmp_path / 'killed', slow)  # checks every run exactly once
    assert np.array_equal(runs['run'], np.arange(160))
    assert_same_runs(runs, run_chunk(slow, np.arange(160)))
    client.wait_for_workers(2, timeout=60)


def test_failed_runs_are_recorded_with_seed_and_parameters_and_counted(tmp_path):
    failing = spec(runs=40, dispersions={
        'omega_body': {'sigma': [120.0, 120.0, 120.0]},  # some above 2 rad per 0.01 s step
        'effects': {'viscous_damping': {'coefficient': {'sigma': 0.02}}}})  # some negative
    result = run_campaign(failing, tmp_path, serial=True, plot=False)
    runs = read_runs(tmp_path, failing)
    reasons = {FAILURE_REASONS[r] for r in runs['reason'][runs['failed']]}
    assert reasons == {'effect parameter out of range', 'rate beyond the RK4 step limit'}
    assert 0 < result.failed < 40 and result.failed == int(runs['failed'].sum())
    assert np.all(np.isfinite(runs['attitude'][~runs['failed']]))
    assert np.all(np.isnan(runs['pointing_error_deg'][runs['failed'], -1]))
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['failed'] == result.failed and summary['succeeded'] == 40 - result.failed
    listed = summary['failed_runs'][0]
    assert {'run', 'seed', 'reason', 'failed_at', 'omega_body0',
            'effect.viscous_damping.coefficient'} <= set(listed)
    assert int(listed['seed']) == int(runs['seed'][listed['run']])


def test_a_run_whose_state_goes_non_finite_is_failed_and_the_campaign_goes_on(tmp_path):
    scene = {**SCENE, 'effects': [{'constant_torque': {'torque': [0.0, 0.0, 0.0]}}]}
    blowing_up = spec_from_mapping({
        'scene': scene, 'runs': 12, 'seed': 1, 'duration': 1.0, 'chunk': 5,
        'dispersions': {'effects': {'constant_torque': {'torque': {
            'uniform': [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0e+74]]}}}}})
    result = run_campaign(blowing_up, tmp_path, serial=True)
    assert result.failed == 12 and result.failures['non-finite state'] > 0
    assert np.all(np.isnan(result.statistics['rate']))
    assert (tmp_path / 'summary.png').is_file()


def test_the_shipped_example_spec_loads(tmp_path):
    files = sorted(path for folder in config_folders('campaigns')
                   for path in folder.glob('*.yaml'))
    assert files
    for path in files:
        loaded = load_spec(path)
        assert loaded.runs >= 1000 and loaded.inertia is not None
        assert loaded.commands or loaded.closed_loop


@pytest.mark.parametrize('change, key', [
    ({'runs': 0}, 'runs'),
    ({'runs': 'many'}, 'runs'),
    ({'duration': -1.0}, 'duration'),
    ({'output_times': [0.5, 2.0]}, 'output_times'),
    ({'dispersions': {'attitude': {'cone_deg': 400}}}, 'dispersions.attitude.cone_deg'),
    ({'dispersions': {'attitude': 'euler'}}, 'dispersions.attitude'),
    ({'dispersions': {'inertia': {'axes': 'random'}}}, 'dispersions.inertia.axes'),
    ({'dispersions': {'omega_body': {'sigma': [1, 2]}}}, 'dispersions.omega_body.sigma'),
    ({'dispersions': {'effects': {'gravity_gradient': {}}}}, 'dispersions.effects'),
    ({'dispersions': {'effects': {'viscous_damping': {'colour': {'sigma': 1}}}}},
     'dispersions.effects.viscous_damping.colour'),
    ({'dispersions': {'wind': 1}}, "'wind' in dispersions"),
    ({'commands': [{'time': 0.0, 'torque': [1, 2]}]}, 'commands[0].torque'),
    ({'statistics': {'percentiles': [50, 101]}}, 'statistics.percentiles'),
    ({'scene': 'no_such_scene'}, "scene: Unknown scene 'no_such_scene'"),
])
def test_spec_errors_are_one_line_naming_the_key(tmp_path, capsys, change, key):
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump({**SPEC, **change}))
    with pytest.raises(SpecError) as error:
        load_spec(path)
    text = str(error.value)
    assert text.startswith(f'Campaign file {str(path)!r}') and key in text
    assert '\n' not in text
    assert main([str(path), '--out', str(tmp_path / 'out'), '--serial']) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith('error: ') and key in err


def test_cli_runs_a_campaign_and_refuses_bad_options(tmp_path, capsys):
    path = tmp_path / 'box.yaml'
    path.write_text(yaml.safe_dump(SPEC))
    assert main([str(path), '--out', str(tmp_path / 'out'), '--serial', '--no-progress']) == 0
    out = capsys.readouterr().out
    assert '60 runs, 0 failed' in out and 'pointing_error_deg at 1 s' in out
    for argv in ([str(path)], [str(path), '--out', 'x', '--workers', '-1'],
                 [str(path), '--out', 'x', '--serial', '--workers', '2'],
                 [str(tmp_path / 'missing.yaml'), '--out', 'x', '--serial'],
                 ['replay', '--out', 'x'],
                 [str(path), '--out', str(tmp_path / 'o'), '--scheduler', 'tcp://127.0.0.1:9']):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count('\n') == 1 and err.startswith('error: '), err


def test_fleet_replay_tabulates_every_bag_with_ground_truth_where_present(tmp_path, client):
    case = build_case('constant_rate')
    scene = write_scene(case, tmp_path)
    bags = tmp_path / 'bags'
    bags.mkdir()
    write_case_bag(case, bags / 'with_truth')
    write_bag(bags / 'no_truth', stamps=case.stamps, rates=case.rates)
    (bags / 'broken.mcap').write_bytes(b'not a bag')
    rows = replay_fleet([bags / 'broken.mcap', bags / 'no_truth', bags / 'with_truth'],
                        tmp_path / 'out', ReplayOptions(scene=str(scene),
                                                        ground_truth_topic='ground_truth'),
                        client=client)
    assert [row['status'] for row in rows] == ['error', 'ok', 'ok']
    assert rows[0]['error'] and rows[1]['truth_samples'] == 0
    assert rows[2]['truth_samples'] > 0 and rows[2]['error_max_deg'] < 1e-6
    assert rows[1]['gyro_messages'] == rows[2]['gyro_messages'] == len(case.stamps)
    assert (tmp_path / 'out' / 'with_truth_replayed' / 'metadata.yaml').is_file()
    table = (tmp_path / 'out' / 'fleet.csv').read_text().splitlines()
    assert len(table) == 4 and table[0].startswith('bag,status')


def test_fleet_replay_cli_takes_a_folder_and_replay_options(tmp_path, capsys):
    case = build_case('constant_rate')
    scene = write_scene(case, tmp_path)
    bags = tmp_path / 'bags'
    bags.mkdir()
    for name in ('a', 'b'):
        write_case_bag(case, bags / name)
    code = main(['replay', str(bags), '--out', str(tmp_path / 'out'), '--serial',
                 '--scene', str(scene), '--ground-truth', 'ground_truth', '--no-progress'])
    out = capsys.readouterr().out
    assert code == 0 and '2 bags, 0 not replayed' in out and out.count('| ok |') == 2
    assert main(['replay', str(tmp_path / 'nothing*'), '--out', str(tmp_path / 'o2'),
                 '--serial']) == 2
    assert 'No bag in' in capsys.readouterr().err
    assert main(['replay', str(bags), '--out', str(tmp_path / 'o3'), '--serial',
                 '--max-dt', 'x']) == 2


def test_the_local_cluster_keeps_glibc_thresholds_and_rare_dask_sampling():
    with local_cluster(1) as cluster, Client(cluster) as dask_client:
        seen = dask_client.run(lambda: (
            os.environ.get('MALLOC_TRIM_THRESHOLD_'),
            __import__('dask').config.get('distributed.worker.profile.enabled')))
    assert list(seen.values()) == [(None, False)]


def one_error_line(err: str, *keys: str) -> None:
    """stderr is exactly one ``error:`` line naming every key (no traceback)."""
    assert err.count('\n') == 1 and err.startswith('error: '), err
    assert 'Traceback' not in err
    for key in keys:
        assert key in err, err


@pytest.mark.parametrize('change, keys', [
    ({'output_times': {'every': 1.0e-12}, 'duration': 60.0},
     ('output_times.every', '6e+13 output times', 'at most 10000')),
    ({'output_times': {'every': 1.0e-320}}, ('output_times.every', 'at most 10000')),
    ({'duration': 1.0e+12, 'output_times': [1.0]},
     ('duration', 'steps of 0.01 s per run', 'at most 1e+09')),
    ({'runs': 10 ** 9, 'duration': 1.0e+6, 'output_times': [1.0]},
     ('runs', 'body-steps', 'at most 1e+14')),
    ({'runs': 10 ** 9, 'chunk': 1}, ('chunk', 'tasks', 'at most 100000')),
    ({'runs': 10 ** 9, 'chunk': 10 ** 5, 'output_times': {'every': 1.0e-4}},
     ('runs', 'of results; at most', "quarter of this machine's memory")),
])
def test_a_spec_beyond_what_the_engine_can_hold_is_refused_in_one_line(tmp_path, capsys,
                                                                       change, keys):
    path = tmp_path / 'huge.yaml'
    path.write_text(yaml.safe_dump({**SPEC, **change}))
    out = tmp_path / 'out'
    assert main([str(path), '--out', str(out), '--serial']) == 2
    one_error_line(capsys.readouterr().err, *keys)
    assert not out.exists()


def test_the_budget_estimates_steps_rows_and_memory_against_the_machine():
    small = spec()
    cost = estimate(small)
    assert cost.steps_per_run == 100 + 2 + 4 and cost.body_steps == 60 * cost.steps_per_run
    assert cost.chunks == 4 and cost.result_bytes == 60 * cost.row_bytes
    assert budget_problem(small) == ''
    # The same campaign on a machine with 64 kB: its results no longer fit.
    assert budget_problem(small, memory=64_000).startswith('runs: 60 runs of 4 output times')
    # A task of all 60 runs fits where the gathered results do, but not its working memory.
    whole = spec(chunk=60)
    memory = 8 * estimate(whole).result_bytes
    assert budget_problem(whole, memory=memory).startswith('chunk: 60 runs per task need')
    assert "eighth of this machine's memory" in budget_problem(whole, memory=memory)
    # The limits themselves, just past them.
    with pytest.raises(SpecError, match='^duration: '):
        spec(duration=(MAX_STEPS_PER_RUN + 1) * 0.01, output_times=[1.0])
    spec(duration=(MAX_STEPS_PER_RUN - 10) * 0.01, output_times=[1.0], runs=1)
    with pytest.raises(SpecError, match='^runs: .* body-steps'):
        spec(runs=10 ** 9, chunk=10 ** 7, duration=MAX_BODY_STEPS / 10 ** 9 * 0.02,
             output_times=[1.0])


TASK_PEAK = """
import json, sys, tracemalloc
from rigid_body_attitude.tools.campaign import run_chunk, spec_from_mapping
spec = spec_from_mapping(json.loads(sys.argv[1]))
run_chunk(spec, range(2))
tracemalloc.start()
run_chunk(spec, range(spec.runs))
print(tracemalloc.get_traced_memory()[1])
"""


def test_a_task_stays_within_its_estimated_memory_and_holds_no_list_of_steps():
    """tracemalloc sees every NumPy and Python allocation of a task (in a process of its own,
    no other thread allocating): its peak is within the estimate, and a hundred times the
    steps leave it unchanged (no per-step list)."""
    peaks = []
    for duration, runs, every in ((2.0, 64, 0.5), (200.0, 64, 50.0), (2.0, 2048, 0.1)):
        mapping = {**SPEC, 'runs': runs, 'chunk': runs, 'duration': duration,
                   'output_times': {'every': every}}
        done = subprocess.run([sys.executable, '-P', '-c', TASK_PEAK, json.dumps(mapping)],
                              capture_output=True, text=True, timeout=600, check=True)
        peaks.append(int(done.stdout))
        assert peaks[-1] <= estimate(spec_from_mapping(mapping)).task_bytes
    assert abs(peaks[1] - peaks[0]) < 0.1 * peaks[0], peaks


def test_a_failed_campaign_leaves_out_as_found_and_the_next_one_runs(tmp_path, capsys):
    path = tmp_path / 'box.yaml'
    path.write_text(yaml.safe_dump(SPEC))
    out = tmp_path / 'out'
    # No scheduler at that address: the campaign fails before any chunk is finished.
    assert main([str(path), '--out', str(out), '--scheduler', 'tcp://127.0.0.1:9']) == 2
    one_error_line(capsys.readouterr().err, 'scheduler')
    assert not out.exists()
    # A campaign.json without any chunk (a campaign that finished none) is taken over.
    out.mkdir()
    (out / 'campaign.json').write_text(json.dumps({'spec_digest': 'another campaign'}))
    other = tmp_path / 'other.yaml'
    other.write_text(yaml.safe_dump({**SPEC, 'seed': 12, 'runs': 20}))
    assert main([str(other), '--out', str(out), '--serial', '--no-progress']) == 0
    assert '20 runs, 0 failed' in capsys.readouterr().out
    # Now the folder holds finished chunks of that campaign: another one is refused.
    assert main([str(path), '--out', str(out), '--serial']) == 2
    one_error_line(capsys.readouterr().err, 'finished chunks of another campaign')


def test_an_interrupted_campaign_process_exits_130_and_resumes(tmp_path):
    slow = {**SPEC, 'runs': 96, 'chunk': 8, 'duration': 4.0}
    path = tmp_path / 'slow.yaml'
    path.write_text(yaml.safe_dump(slow))
    out = tmp_path / 'out'
    command = [sys.executable, '-m', 'rigid_body_attitude.tools.campaign', str(path),
               '--out', str(out), '--serial', '--no-progress']
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120.0
    chunks = out / 'chunks'
    while time.monotonic() < deadline and process.poll() is None and not (
            chunks.is_dir() and any(chunks.glob('*.parquet'))):
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130
    one_error_line(err, 'interrupted', 'resume')
    finished = len(list((out / 'chunks').glob('*.parquet')))
    assert 1 <= finished < 12
    assert not list((out / 'chunks').glob('*.tmp'))
    resumed = run_campaign(spec_from_mapping(slow), out, serial=True, plot=False)
    assert (resumed.chunks_run, resumed.chunks_resumed) == (12 - finished, finished)
    assert_same_runs(read_runs(out, spec_from_mapping(slow)),
                     run_chunk(spec_from_mapping(slow), range(96)))


SLEW_SPEC = {'name': 'slew_test', 'scene': 'slew', 'runs': 24, 'seed': 5, 'duration': 40.0,
             'output_times': {'every': 10.0}, 'chunk': 8,
             'dispersions': {'inertia': {'second_moments_sigma': 0.1, 'axes': {'cone_deg': 5}},
                             'attitude': {'cone_deg': 10.0},
                             'effects': {'attitude_pd': {'kp': {'relative_sigma': 0.05},
                                                         'target_rpy': {'sigma': 0.01}}}},
             'statistics': {'settling_deg': 1.0}}


def test_a_closed_loop_campaign_converges_with_settling_times_and_torque_used(tmp_path,
                                                                              client):
    dispersions = {**SLEW_SPEC['dispersions'],
                   'effects': {'attitude_pd': {'kp': {'relative_sigma': 0.05}}}}
    slew = spec_from_mapping({**SLEW_SPEC, 'dispersions': dispersions})
    result = run_campaign(slew, tmp_path, client=client, plot=False)
    runs = read_runs(tmp_path, slew)
    assert result.failed == 0
    final_error = runs['pointing_error_deg'][:, -1]
    assert np.all(final_error < 1.0) and np.all(runs['pointing_error_deg'][:, 0] > 30.0)
    settling = runs['settling_time_s']
    assert np.all(np.isfinite(settling)) and np.all((5.0 < settling) & (settling < 30.0))
    # Once settled, every output time after it is within the threshold.
    times = np.array((0.0,) + slew.output_times)
    assert np.all(runs['pointing_error_deg'][times[None, :] >= settling[:, None]] <= 1.0)
    # The torque saturates on every axis at the start: peak |τ| = √3 × 0.5 N m.
    limit = 0.5 * np.sqrt(3.0)
    assert np.all(runs['torque_peak'] <= limit * (1 + 1e-12))
    assert np.all(runs['torque_integral'] > 1.0)
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['closed_loop']['settled'] == 24
    assert summary['closed_loop']['percentiles']['settling_time_s'] == \
        result.closed_loop['percentiles']['settling_time_s']


def test_a_run_of_a_closed_loop_campaign_is_the_single_body_propagator_with_its_draws():
    """The node's propagator, given a run's drawn inertia, attitude, rate, gain and target,
    takes the same steps and samples as that run in the batch (same law, same instants)."""
    slew = spec_from_mapping({**SLEW_SPEC, 'duration': 12.0, 'output_times': [3.0, 12.0]})
    run = 3
    batch_run = run_chunk(slew, [run])
    drawn = sample_runs(slew, [run])
    pd = dict(dict(slew.scene.effects)['attitude_pd'])
    pd['kp'] = float(drawn.effects['attitude_pd']['kp'][0])
    pd['target_rpy'] = drawn.effects['attitude_pd']['target_rpy'][0].tolist()
    scene = scene_from_mapping({
        'name': 'one_run', 'rate_source': 'dynamics', 'step': slew.scene.step,
        'body': {'mass': 100.0, 'inertia': {'tensor': drawn.inertia[0].tolist()}},
        'initial_state': {'attitude': drawn.attitude[0].tolist(),
                          'omega_body': drawn.omega_body[0].tolist()},
        'effects': [{'attitude_pd': pd}]})
    propagator = DynamicsPropagator(scene)
    for output_time in (3.0, 12.0):
        propagator.advance_to(output_time)
    error = quaternion.attitude_error(propagator.state.attitude, batch_run['attitude'][0])
    assert float(error) < 1e-12
    assert np.max(np.abs(propagator.state.omega_body - batch_run['omega_body'][0])) < 1e-12
    integral, peak = propagator.effects[0].torque_used(propagator.state.time)
    assert abs(integral - batch_run['torque_integral'][0]) < 1e-12 * integral
    assert peak == pytest.approx(batch_run['torque_peak'][0], rel=1e-14)


def test_closed_loop_spec_and_scene_mistakes_are_one_line(tmp_path, capsys):
    assert load_scene('slew').effects[0][0] == 'attitude_pd'
    base = {'name': 's', 'rate_source': 'dynamics', 'step': 0.01,
            'body': {'mass': 1.0, 'inertia': {'moments': [1.0, 2.0, 2.5]}}}
    with pytest.raises(SceneError, match='control_period 0.015 s must be a whole number of '
                                         'steps of 0.01 s'):
        scene_from_mapping({**base, 'effects': [{'attitude_pd': {
            'kp': 1.0, 'kd': 1.0, 'control_period': 0.015}}]})
    with pytest.raises(SceneError, match="parameter 'target_attitude' is named "
                                         "'target_attitude_wxyz': rename it"):
        scene_from_mapping({**base, 'effects': [{'attitude_pd': {
            'kp': 1.0, 'kd': 1.0, 'control_period': 0.01, 'target_attitude': [1, 0, 0, 0]}}]})
    for change, key in [
            ({'dispersions': {'effects': {'attitude_pd': {
                'target_attitude': {'sigma': 0.01}}}}},
             "dispersions.effects.attitude_pd.target_attitude: the parameter is named "
             "'target_attitude_wxyz'"),
            ({'dispersions': {'effects': {'attitude_pd': {
                'control_period': {'sigma': 0.01}}}}},
             'dispersions.effects.attitude_pd.control_period: every run shares'),
            ({'scene': SCENE, 'dispersions': {}, 'statistics': {'settling_deg': 1.0}},
             'statistics.settling_deg needs a scene with the attitude_pd effect'),
            ({'statistics': {'settling_deg': 0.0}}, 'statistics.settling_deg')]:
        path = tmp_path / 'bad.yaml'
        path.write_text(yaml.safe_dump({**SLEW_SPEC, **change}))
        assert main([str(path), '--out', str(tmp_path / 'out'), '--serial']) == 2
        one_error_line(capsys.readouterr().err, key)
