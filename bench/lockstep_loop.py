"""Lockstep loop benchmark: the real-time factor a closed loop reaches, node + controller.

For each control rate (``--rates``, default 100 and 1000 Hz) it starts, as a user would, the
node (``propagation_node``, a slew scene of the ``commanded_torque`` kind, ``lockstep``,
``real_time_factor`` 0: as fast as the loop allows, ``publish_clock`` on) and the
package's ``attitude_controller`` (orientation + twist in, torque out), lets the loop warm up, then
reads the node's ``/diagnostics`` for ``--duration`` seconds: the achieved real-time factor of
each one-second period (sim seconds per wall second) and the lockstep timeouts. Per rate it
prints the median factor, the ticks per wall second, and each process's CPU per tick
(/proc/<pid>/task/*/schedstat), which says where a tick's time goes.

Example::

    python bench/lockstep_loop.py                 # 100 and 1000 Hz, 6 s each
    python bench/lockstep_loop.py --rates 100 --duration 10
    python bench/lockstep_loop.py --step 0.01     # one integration step per 100 Hz tick
"""

import argparse
from pathlib import Path
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from _common import cpu_seconds, ros_env

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


def command(name: str) -> list:
    """An installed console script (``propagation_node``, ``attitude_controller``)."""
    return [shutil.which(name) or str(Path(sys.executable).parent / name)]


def diagnostics_reader(domain_id: int):
    """An rclpy context, node and list of (achieved factor, timeouts) per /diagnostics."""
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
                periods.append((float(values['achieved_real_time_factor']),
                                int(values.get('lockstep_timeouts', '0')),
                                float(values['sim_time [s]']),
                                float(values['real_time_factor'])))
    node.create_subscription(DiagnosticArray, '/diagnostics', take, 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    return context, executor, periods


def measure(rate_hz: float, duration: float, warmup: float, domain_id: int,
            scene: str, step: float) -> dict:
    """One loop at ``rate_hz``: the achieved factors and CPU per tick."""
    env = ros_env(domain_id)
    context, executor, periods = diagnostics_reader(domain_id)
    namespace = f'/lockstep_{int(rate_hz)}'
    node = subprocess.Popen(command('propagation_node') + [
        '--ros-args', '-r', f'__ns:={namespace}', '-p', f'scene:={scene}',
        '-p', 'lockstep:=true', '-p', 'publish_clock:=true', '-p', 'real_time_factor:=0.0',
        '-p', f'publish_rate:={rate_hz}', '-p', f'step:={step}'], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    controller = subprocess.Popen(command('attitude_controller') + [
        '--ros-args', '-r', f'__ns:={namespace}', '-p', 'torque_limit:=0.02'], env=env,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + warmup
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        skip = len(periods)
        cpu0 = (cpu_seconds(node.pid), cpu_seconds(controller.pid))
        deadline = time.monotonic() + duration
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        cpu1 = (cpu_seconds(node.pid), cpu_seconds(controller.pid))
    finally:
        controller.terminate()
        node.terminate()
        controller.wait(10)
        node.wait(10)
        executor.shutdown()
        context.try_shutdown()
    window = [period for period in periods[skip:] if period[0] > 0.0]
    sim_seconds = window[-1][2] - window[0][2] if len(window) > 1 else 0.0
    ticks = sim_seconds * rate_hz
    return {
        'rate_hz': rate_hz,
        'factors': [round(period[0], 2) for period in window],
        'median_factor': statistics.median(period[0] for period in window) if window else 0.0,
        'timeouts': window[-1][1] if window else -1,
        'ticks_per_wall_s': statistics.median(period[0] for period in window) * rate_hz
        if window else 0.0,
        # integrate + publish per tick, from the node's own timing (sim s per s of work)
        'tick_work_us': 1e6 / rate_hz / statistics.median(period[3] for period in window)
        if window else 0.0,
        'node_cpu_us_per_tick': (cpu1[0] - cpu0[0]) / ticks * 1e6 if ticks else 0.0,
        'controller_cpu_us_per_tick': (cpu1[1] - cpu0[1]) / ticks * 1e6 if ticks else 0.0,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rates', default='100,1000', help='control rates [Hz]')
    parser.add_argument('--duration', type=float, default=6.0, help='measured seconds')
    parser.add_argument('--warmup', type=float, default=4.0, help='seconds before measuring')
    parser.add_argument('--domain-id', type=int, default=77)
    parser.add_argument('--step', type=float, default=0.0,
                        help='integration step [s] (0 = the scene\'s, 1 ms)')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / 'slew.yaml'
        scene.write_text(SCENE)
        for rate in (float(r) for r in args.rates.split(',')):
            row = measure(rate, args.duration, args.warmup, args.domain_id, str(scene),
                          args.step)
            print(f"{row['rate_hz']:6.0f} Hz: real-time factor {row['median_factor']:.1f}x "
                  f"(per second: {row['factors']}), {row['ticks_per_wall_s']:.0f} ticks/s, "
                  f"lockstep timeouts {row['timeouts']}; per tick: node integrate + publish "
                  f"{row['tick_work_us']:.0f} us, node CPU {row['node_cpu_us_per_tick']:.0f} us, "
                  f"controller CPU {row['controller_cpu_us_per_tick']:.0f} us")
    return 0


if __name__ == '__main__':
    sys.exit(main())
