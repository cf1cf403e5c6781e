"""Lockstep loop benchmark: the real-time factor a closed loop reaches, node + controller.

For each controller (``--controllers``) and control rate (``--rates``, default 100 and
1000 Hz) it starts, as a user would, the node (``propagation_node``, a slew scene of the
``commanded_torque`` kind, ``lockstep``, ``real_time_factor`` 0: as fast as the loop allows,
``publish_clock`` on) and the controller, each a process of its own:

* ``attitude_controller``: the package's (``odom`` in, ``torque`` out);
* ``plain``: ``bench/plain_controller.py``, the plain rclpy controller of
  docs/closed-loop.md (a typed ``odom`` subscription on rclpy's stock executor, ``rclpy.spin``),
  started with the environment as it is (no Fast DDS profile of the package);
* ``plain+profile``: the same with the package's Fast DDS profile
  (``FASTRTPS_DEFAULT_PROFILES_FILE``, as docs/tuning.md advises for the node's peers).

After a warm-up it reads the node's ``/diagnostics`` for ``--duration`` seconds: the achieved
real-time factor of each one-second period (sim seconds per wall second) and the lockstep
timeouts. At each ``/diagnostics`` message it also reads every thread's run time and
voluntary context switches (/proc/<pid>/task/*/schedstat and status), so the per-tick budget
covers the same ticks: the node's and the controller's main threads (Python: integration,
encoding, the wait, taking and publishing), their middleware threads (Fast DDS's
shared-memory listeners and event thread) and the wake-ups (voluntary context switches) per
tick. What is left of a tick's wall time is waiting: one process for the other, and both for
a CPU (the machine's load average is printed beside each row).

Example::

    python bench/lockstep_loop.py                 # the three controllers, 100 and 1000 Hz
    python bench/lockstep_loop.py --controllers plain --rates 100 --duration 10
"""

import argparse
import os
from pathlib import Path
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from _common import ros_env, thread_stats

SCENE = """name: slew_under_pd
description: a box 60 deg from the identity, driven by commanded torques
rate_source: dynamics
integrator: rk4
step: 0.001
body:
  mass: 2.0
  inertia: {box: {edges: [0.1, 0.2, 0.3], about: centre}}
initial_state:
  attitude: [0.8660254037844387, 0.28867513459481287, 0.28867513459481287,
             0.28867513459481287]
  omega_body: [0.0, 0.0, 0.0]
effects:
  - commanded_torque: {timeout: 0.5}
"""
GAINS = ['-p', 'kp:=0.05', '-p', 'kd:=0.04', '-p', 'torque_limit:=0.02']
PLAIN_CONTROLLER = Path(__file__).resolve().parent / 'plain_controller.py'


def command(name: str) -> list:
    """An installed console script (``propagation_node``, ``attitude_controller``)."""
    return [shutil.which(name) or str(Path(sys.executable).parent / name)]


def controller_command(controller: str) -> list:
    """The command line of ``controller`` (``attitude_controller``, ``plain``,
    ``plain+profile``)."""
    if controller.startswith('plain'):
        return [sys.executable, str(PLAIN_CONTROLLER), '--ros-args', *GAINS]
    return command('attitude_controller') + ['--ros-args', *GAINS]


def budget(pid: int, before: dict, after: dict) -> dict:
    """Run ns and wake-ups between two :func:`_common.thread_stats` snapshots: the main thread, the
    middleware's threads (``dds.*``) and the rest."""
    parts = {'main': 0, 'middleware': 0, 'other': 0, 'wakeups': 0}
    for tid, (name, run_ns, switches) in after.items():
        _, run0, switches0 = before.get(tid, (name, 0, 0))
        part = 'main' if tid == pid else 'middleware' if name.startswith('dds.') else 'other'
        parts[part] += run_ns - run0
        parts['wakeups'] += switches - switches0
    return parts


def diagnostics_reader(domain_id: int, pids: tuple):
    """An rclpy context, executor and the list of per-period records of /diagnostics: the
    node's values and, read as each message arrives, the threads of ``pids``."""
    import rclpy
    from rclpy.context import Context
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = Node('lockstep_bench', context=context)
    periods = []

    def take(array) -> None:
        for status in array.status:
            values = {v.key: v.value for v in status.values}
            if 'achieved_real_time_factor' in values:
                periods.append({
                    'factor': float(values['achieved_real_time_factor']),
                    'timeouts': int(values.get('lockstep_timeouts', '0')),
                    'sim_time': float(values['sim_time [s]']),
                    'work_factor': float(values['real_time_factor']),
                    'wall': time.monotonic(),
                    'threads': [thread_stats(pid) for pid in pids]})
    node.create_subscription(DiagnosticArray, '/diagnostics', take, 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    return context, executor, periods


def measure(controller: str, rate_hz: float, duration: float, warmup: float, domain_id: int,
            scene: str) -> dict:
    """One loop at ``rate_hz``: the achieved factors and the per-tick budget."""
    env = ros_env(domain_id)
    namespace = f'/lockstep_{int(rate_hz)}'
    node = subprocess.Popen(command('propagation_node') + [
        '--ros-args', '-r', f'__ns:={namespace}', '-p', f'scene:={scene}',
        '-p', 'lockstep:=true', '-p', 'publish_clock:=true', '-p', 'real_time_factor:=0.0',
        '-p', f'publish_rate:={rate_hz}'], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    loop_env = dict(env)
    if controller == 'plain+profile':
        from rigid_body_attitude.ros.middleware import packaged_fastdds_profile
        loop_env['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(packaged_fastdds_profile())
    loop = subprocess.Popen(controller_command(controller) + ['-r', f'__ns:={namespace}'],
                            env=loop_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    context, executor, periods = diagnostics_reader(domain_id, (node.pid, loop.pid))
    load = [os.getloadavg()[0]]
    try:
        deadline = time.monotonic() + warmup
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        skip = len(periods)
        deadline = time.monotonic() + duration
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        load.append(os.getloadavg()[0])
    finally:
        loop.terminate()
        node.terminate()
        loop.wait(10)
        node.wait(10)
        executor.shutdown()
        context.try_shutdown()
    return summary(controller, rate_hz, [p for p in periods[skip:] if p['factor'] > 0.0], load)


def summary(controller: str, rate_hz: float, window: list, load: list) -> dict:
    """The row of one loop from its diagnostics periods (first to last message)."""
    row = {'controller': controller, 'rate_hz': rate_hz, 'load': load, 'periods': len(window)}
    if len(window) < 2:
        return row
    first, last = window[0], window[-1]
    ticks = round((last['sim_time'] - first['sim_time']) * rate_hz)
    wall = last['wall'] - first['wall']
    for index, name in enumerate(('node_budget', 'controller_budget')):
        before, after = first['threads'][index], last['threads'][index]
        parts = budget(min(after), before, after)  # the main thread's id: the process's
        row[name] = {key: value / ticks * (1.0 if key == 'wakeups' else 1e-3)
                     for key, value in parts.items()}  # per tick; run time in us
    factors = [period['factor'] for period in window[1:]]
    row.update({
        'factors': [round(factor, 1) for factor in factors],
        'median_factor': statistics.median(factors),
        'ticks_per_s': ticks / wall,
        'wall_us': wall / ticks * 1e6,
        'timeouts': last['timeouts'] - first['timeouts'],
        # the node's own timing of integrate + publish (sim s per s of work)
        'tick_work_us': 1e6 / rate_hz / statistics.median(p['work_factor'] for p in window),
    })
    return row


def markdown(rows: list) -> str:
    """The rows as the table of docs/performance.md."""
    lines = ['| controller | control rate | real-time factor (median; per second) | ticks/s '
             '| wall per tick | node: integrate + publish | node main thread | node middleware '
             '| controller main thread | controller middleware | wake-ups per tick (node, '
             'controller) | load average |',
             '|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|']
    for row in rows:
        if 'node_budget' not in row:
            lines.append(f"| {row['controller']} | {row['rate_hz']:g} Hz | no data "
                         f"({row['periods']} periods) | | | | | | | | | |")
            continue
        node, loop = row['node_budget'], row['controller_budget']
        lines.append(
            f"| {row['controller']} | {row['rate_hz']:g} Hz | {row['median_factor']:.1f}× "
            f"({min(row['factors']):.1f}–{max(row['factors']):.1f}) "
            f"| {row['ticks_per_s']:.0f} | {row['wall_us']:.0f} µs | {row['tick_work_us']:.0f} µs "
            f"| {node['main']:.0f} µs | {node['middleware']:.0f} µs | {loop['main']:.0f} µs "
            f"| {loop['middleware']:.0f} µs | {node['wakeups']:.1f}, {loop['wakeups']:.1f} "
            f"| {row['load'][0]:.1f}–{row['load'][-1]:.1f} |")
    return '\n'.join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--controllers', default='attitude_controller,plain,plain+profile',
                        help='attitude_controller, plain and/or plain+profile')
    parser.add_argument('--rates', default='100,1000', help='control rates [Hz]')
    parser.add_argument('--duration', type=float, default=8.0, help='measured seconds')
    parser.add_argument('--warmup', type=float, default=4.0, help='seconds before measuring')
    parser.add_argument('--domain-id', type=int, default=77)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / 'slew.yaml'
        scene.write_text(SCENE)
        for controller in args.controllers.split(','):
            for rate in (float(r) for r in args.rates.split(',')):
                rows.append(measure(controller, rate, args.duration, args.warmup,
                                    args.domain_id, str(scene)))
                print(markdown(rows[-1:]).splitlines()[-1], flush=True)
    print()
    print(markdown(rows))
    for row in rows:
        print(f"{row['controller']} {row['rate_hz']:g} Hz: per second {row.get('factors')}, "
              f"lockstep timeouts {row.get('timeouts')}, other threads: node "
              f"{row.get('node_budget', {}).get('other', 0):.0f} us, controller "
              f"{row.get('controller_budget', {}).get('other', 0):.0f} us per tick")
    return 0


if __name__ == '__main__':
    sys.exit(main())
