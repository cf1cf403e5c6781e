"""CPU of the installed node on every shipped dynamics scene, unsubscribed and fully subscribed.

For each shipped scene with ``rate_source: dynamics`` it starts, as a user would,
``propagation_node --ros-args -p scene:=NAME`` (default parameters otherwise: 50 Hz ticks),
waits until it serves, lets it warm up (``--warmup``), then measures the process's CPU
(the run time of all its threads in ns, /proc/<pid>/task/*/schedstat) over ``--duration``
seconds twice:

1. with nobody subscribed to any output;
2. with ``bench/_output_subscriber.py`` subscribed to every output of the node
   (``orientation``, ``pose``, ``twist``, ``energy``, ``angular_momentum``,
   ``/diagnostics``), counting what arrives: a scene that falls behind real time shows up as
   fewer than ``publish_rate`` poses per second.

It also times the scene's propagator alone in this process (advancing to the same 50 Hz
tick times, no ROS): the node's CPU minus that is the node's own per-tick cost.

Targets (issue 13, item 2): at most 3 % of one core unsubscribed, 5 % subscribed. The
machine is shared: the other load (the run time of every process but the node, the
subscriber and this script) is reported per row. Results go to
``bench/results/node/node_dynamics_cpu.json``; ``bench/performance_report.py`` puts them in
``docs/performance.md``.

Example::

    python bench/node_dynamics_cpu.py
    python bench/node_dynamics_cpu.py --scenes torque_free_box,heavy_top --duration 5
"""

import argparse
import json
import os
from pathlib import Path
import shlex
import signal
import sys
import tempfile
import time
from typing import Dict, List, Optional

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

from _common import (cpu_by_thread_name, cpu_seconds, other_load_ticks,  # noqa: E402
                     process_ticks, thread_run_ns)
import _report  # noqa: E402
from node_throughput import CLOCK_TICKS, display, ProcessCrashed, Session  # noqa: E402

#: Targets of issue 13 (% of one core).
UNSUBSCRIBED_TARGET = 3.0
SUBSCRIBED_TARGET = 5.0
SERVING_LINE = b']: serving'


def dynamics_scenes() -> List[str]:
    """Names of the shipped scenes whose rate source is ``dynamics``."""
    from rigid_body_attitude.core.scene import builtin_scenes, load_scene
    return [name for name in builtin_scenes() if load_scene(name).rate_source == 'dynamics']


def propagator_percent(scene: str, rate: float = 50.0, seconds: float = 4.0) -> float:
    """CPU (% of one core) of the scene's propagator alone, in this process, advancing to the
    node's tick times at ``rate`` Hz as the node does (no ROS): the part of the node's CPU
    that the propagator and its effects cost."""
    from rigid_body_attitude.core.propagator import build_propagator
    from rigid_body_attitude.session.settings import load_node_scene
    propagator = build_propagator(load_node_scene(scene))
    ticks = int(seconds * rate)
    propagator.advance_to(1.0 / rate)  # warm-up (first calls build caches)
    start = time.thread_time_ns()
    for k in range(2, ticks + 2):
        propagator.advance_to(k / rate)
    return 100.0 * (time.thread_time_ns() - start) * 1e-9 / seconds


def output_topics() -> str:
    """``topic=type`` of every output a dynamics scene publishes (no ``imu/data``)."""
    from rigid_body_attitude.session.settings import OUTPUT_TOPICS
    return ','.join(f'{topic}={kind}' for topic, kind in OUTPUT_TOPICS.items()
                    if topic != 'imu/data')


def node_command() -> List[str]:
    """``propagation_node`` next to this interpreter (a venv's bin), else on PATH."""
    beside = Path(sys.executable).parent / 'propagation_node'
    return [str(beside) if beside.is_file() else 'propagation_node']


def wait_serving(process, timeout: float) -> None:
    """Wait until the node's log says it serves (its ``serving`` line)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        process.check_alive()
        if SERVING_LINE in process.log_path.read_bytes():
            return
        time.sleep(0.1)
    raise ProcessCrashed(f'{process.argv} did not start serving within {timeout} s')


def cpu_window(pids: Dict[str, int], seconds: float) -> Dict[str, object]:
    """CPU (% of one core) of each pid and per thread of the node (scheduler run times in ns,
    /proc/<pid>/task/*/schedstat), and the other load: every other process's run time
    (:func:`_common.other_load_ticks`; /proc/stat's tick samples do not add up on this VM)."""
    seconds0 = {name: cpu_seconds(pid) for name, pid in pids.items()}
    threads0 = thread_run_ns(pids['node'])
    machine0, wall0 = process_ticks(), time.monotonic()
    time.sleep(seconds)
    seconds1 = {name: cpu_seconds(pid) for name, pid in pids.items()}
    threads1 = thread_run_ns(pids['node'])
    machine1, window = process_ticks(), time.monotonic() - wall0
    ours = set(pids.values()) | {os.getpid()}
    return {
        **{f'{name}_cpu_percent': 100.0 * (seconds1[name] - seconds0[name]) / window
           for name in pids},
        'node_cpu_by_thread': cpu_by_thread_name(threads0, threads1, window),
        'other_load_cores': other_load_ticks(machine0, machine1, ours) / CLOCK_TICKS / window,
        'window_s': window,
    }


def measure_scene(scene: str, args: argparse.Namespace) -> dict:
    """Both windows for one scene."""
    with tempfile.TemporaryDirectory(prefix='bench_dyn_') as tmp:
        session = Session(args.domain_id, 100, Path(tmp))
        try:
            node = session.start('node', node_command() + ['--ros-args', '-p', f'scene:={scene}']
                                 + shlex.split(args.node_args))
            wait_serving(node, args.match_timeout)
            time.sleep(args.warmup)
            alone = cpu_window({'node': node.popen.pid}, args.duration)
            node.check_alive()
            subscriber = session.start('subscriber', [
                sys.executable, str(BENCH / '_output_subscriber.py'), '--topics',
                output_topics()], json_stdout=True)
            subscriber.wait_event('matched', args.match_timeout, watch=[node])
            time.sleep(args.warmup)
            counted_from = time.monotonic()
            subscribed = cpu_window({'node': node.popen.pid,
                                     'subscriber': subscriber.popen.pid}, args.duration)
            node.check_alive()
            subscriber.popen.send_signal(signal.SIGINT)
            counts = subscriber.wait_event('counts', 10.0)['counts']
            listened_s = time.monotonic() - counted_from + args.warmup
        finally:
            problems = session.close()
    return {'scene': scene, 'unsubscribed': alone, 'subscribed': subscribed,
            'propagator_cpu_percent': propagator_percent(scene),
            'received_per_s': {topic: count / listened_s for topic, count in counts.items()},
            'problems': problems}


def row_text(row: dict) -> str:
    """One terminal line per scene."""
    alone, subscribed = row['unsubscribed'], row['subscribed']
    return (f'{row["scene"]:28s} unsubscribed {alone["node_cpu_percent"]:5.1f} %  '
            f'subscribed {subscribed["node_cpu_percent"]:5.1f} %  propagator alone '
            f'{row["propagator_cpu_percent"]:5.1f} %  pose '
            f'{row["received_per_s"].get("pose", 0.0):5.1f}/s  other load '
            f'{alone["other_load_cores"]:.2f} / {subscribed["other_load_cores"]:.2f} cores')


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scenes', default='',
                        help='comma-separated scenes (default: every shipped dynamics scene)')
    parser.add_argument('--duration', type=float, default=10.0,
                        help='measured seconds per window (default %(default)s)')
    parser.add_argument('--warmup', type=float, default=2.0)
    parser.add_argument('--node-args', default='',
                        help='extra ROS arguments for the node, e.g. "-p publish_rate:=100.0"')
    parser.add_argument('--domain-id', type=int,
                        default=int(os.environ.get('ROS_DOMAIN_ID', '72')))
    parser.add_argument('--match-timeout', type=float, default=30.0)
    parser.add_argument('--results', type=Path,
                        default=BENCH / 'results' / 'node' / 'node_dynamics_cpu.json')
    return parser.parse_args(argv)


def main(argv: Optional[List[str]] = None) -> int:
    """Measure every scene, save and print the results."""
    args = parse_args(argv)
    scenes = args.scenes.split(',') if args.scenes else dynamics_scenes()
    result = {'machine': _report.machine_description(), 'duration_s': args.duration,
              'warmup_s': args.warmup, 'node_args': args.node_args,
              'targets_percent': {'unsubscribed': UNSUBSCRIBED_TARGET,
                                  'subscribed': SUBSCRIBED_TARGET},
              'invocation': display([sys.executable] + sys.argv), 'rows': []}
    problems = []
    for scene in scenes:
        try:
            row = measure_scene(scene, args)
        except ProcessCrashed as err:
            problems.append(f'{scene}: {err}')
            continue
        problems += [f'{scene}: {problem}' for problem in row['problems']]
        result['rows'].append(row)
        print(row_text(row), flush=True)
    result['problems'] = problems
    args.results.parent.mkdir(parents=True, exist_ok=True)
    args.results.write_text(json.dumps(result, indent=1))
    for problem in problems:
        print(f'error: {problem}', file=sys.stderr)
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
