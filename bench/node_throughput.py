"""Node throughput benchmark: loss, CPU and latency of a gyro -> pose node versus rate.

For every rate and every target (the node, the bare ``SingleThreadedExecutor`` relay
``bench/relay.py`` as the anchor, the fast relay ``bench/fast_relay.py``) it starts three fresh
processes exactly as a user would: the target executable, a subscriber of ``pose``
(``bench/_subscriber.py``) and a publisher of ``sensor_msgs/Imu`` on ``imu``
(``bench/_publisher.py``, RELIABLE, KEEP_LAST ``--depth``). Targets alternate within each rate so
background load on the shared machine hits them alike. Per run it reports:

* sent: messages published in the measured window (after a warm-up), and the publisher's
  achieved rate (a publisher that cannot keep up invalidates the row; it is flagged);
* received / lost: poses whose stamp lies in the window, received within ``--drain`` seconds
  after the last publish; anything later or never counts as lost;
* CPU: the target's run time over the window (all threads, /proc/<pid>/task/*/schedstat, in
  ns), in % of one core;
* latency p50 / p99: receive wall time minus pose stamp (= the gyro stamp = publish wall time);
* other load: the CPU of every other process over the window (their scheduler run times from
  /proc/<pid>/stat; /proc/stat's tick samples are unreliable on this VM), since the machine is
  shared.

``--repeats N`` measures each rate in N windows per target, the targets interleaved (their order
rotated every window, so that none always runs first after the previous rate); a row then pools
the windows: latency percentiles over all their poses, the median window's CPU, each window's
row kept under ``windows`` (:func:`pooled_row`).

The results document goes to ``--json`` when given, and a Markdown summary (tables, thread
breakdown at 1 kHz, the node against the fast relay) to ``--report`` (default: stdout). Exit
code 0 unless a process crashed, could not be started, or ignored SIGINT (measured losses
are results, not errors).

Examples::

    python bench/node_throughput.py                      # all targets, default rates
    python bench/node_throughput.py --targets relay,fast_relay --rates 1000,5000 --duration 3
    python bench/node_throughput.py --targets node,fast_relay --repeats 3
    python bench/node_throughput.py --target fast3='python bench/fast_relay.py --outputs \
pose,orientation,imu_data'
    python bench/node_throughput.py --report /tmp/throughput.md --json /tmp/throughput.json
"""

import argparse
import json
import os
from pathlib import Path
import queue
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Dict, List, Optional, Sequence, Tuple, TYPE_CHECKING

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(BENCH))

from _common import (cpu_by_thread_name, cpu_seconds, other_load_ticks,  # noqa: E402
                     process_ticks, QUEUE_DEPTH, ros_env, rss_kib, thread_run_ns)
import _report  # noqa: E402

if TYPE_CHECKING:
    import numpy as np

DEFAULT_RATES = [200, 500, 1000, 2000, 5000, 10000, 15000, 20000]
NODE_ARGS = ['--ros-args', '-p', 'scene:=strapdown']
#: The targets measured when ``--targets`` is not given.
DEFAULT_TARGETS = ('node', 'relay', 'fast_relay')
#: ``node_full``: the node with the whole real-IMU front end besides levelling (which needs
#: ``--imu-accel``): this mount and a calibration file (:data:`CALIBRATION`, written to a
#: temporary folder); ``node_nocov`` is the same without the covariance; ``node_filter`` the
#: same with the ``imu_filter`` scene (the attitude filter: with ``--imu-accel`` gravity and
#: ``--mag-every`` it levels, then runs every update).
FULL_NODE_MOUNT_RPY = '[0.02, -0.03, 1.5707963]'
#: A plain calibration file (``rigid_body_attitude.core.estimation.calibration``): gyro bias,
#: scale and misalignment, applied by the node's inline affine map.
CALIBRATION = ('bias: [0.001, -0.002, 0.0005]\nscale: [1.01, 0.99, 1.0]\n'
               'misalignment: [[1.0, 0.002, 0.0], [0.0, 1.0, -0.001], [0.0, 0.0, 1.0]]\n')
CLOCK_TICKS = os.sysconf('SC_CLK_TCK')


class ProcessCrashed(RuntimeError):
    """A benchmark process exited on its own before the run was over."""


class Process:
    """A child process whose stdout JSON lines are collected by a reader thread."""

    def __init__(self, argv: List[str], env: Dict[str, str], log_path: Path,
                 json_stdout: bool) -> None:
        """Start ``argv``; stderr (and stdout unless ``json_stdout``) go to ``log_path``."""
        self.argv = argv
        self.log_path = log_path
        self.log = open(log_path, 'wb')
        self.events: 'queue.Queue[dict]' = queue.Queue()
        self.popen = subprocess.Popen(
            argv, env=env, cwd=REPO, stdin=subprocess.PIPE,
            stdout=subprocess.PIPE if json_stdout else self.log, stderr=self.log)
        if json_stdout:
            threading.Thread(target=self._read_events, daemon=True).start()

    def _read_events(self) -> None:
        for line in self.popen.stdout:
            try:
                self.events.put(json.loads(line))
            except ValueError:
                self.log.write(line)

    def wait_event(self, name: str, timeout: float, watch: Sequence['Process'] = ()) -> dict:
        """Return the next event called ``name``.

        Raises ProcessCrashed if this process or one in ``watch`` exits meanwhile, or on
        timeout.
        """
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                event = self.events.get(timeout=0.05)
            except queue.Empty:
                for process in (self, *watch):
                    process.check_alive()
                continue
            if event.get('event') == 'error':
                raise ProcessCrashed(f'{self.argv[1]}: {event}')
            if event.get('event') == name:
                return event
        raise ProcessCrashed(f'timed out after {timeout} s waiting for "{name}" from '
                             f'{shlex.join(self.argv)} (log {self.log_path})')

    def check_alive(self) -> None:
        """Raise ProcessCrashed if the process has exited."""
        if self.popen.poll() is not None:
            tail = self.log_path.read_text(errors='replace')[-2000:]
            raise ProcessCrashed(f'{shlex.join(self.argv)} exited with {self.popen.returncode}'
                                 f'\n{tail}')

    def stop(self, sig: int = signal.SIGINT, grace: float = 3.0) -> Optional[str]:
        """Send ``sig``, wait up to ``grace`` s, then SIGKILL; return a problem or None.

        A problem is an exit by a signal other than ``sig`` (a crash) or a process that had
        to be killed (it ignored ``sig``).
        """
        if self.popen.poll() is not None:
            self.log.close()
            return None  # exited earlier; check_alive() reports that while it matters
        problem = None
        try:
            self.popen.stdin.close()
            self.popen.send_signal(sig)
            self.popen.wait(grace)
            code = self.popen.returncode
            if code not in (0, -sig, 128 + sig):
                self.log.flush()
                tail = self.log_path.read_text(errors='replace')[-6000:]
                problem = (f'{shlex.join(self.argv)} exited with {code} on signal {sig}; '
                           f'log tail:\n{tail}')
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait()
            problem = f'{shlex.join(self.argv)} ignored signal {sig} for {grace} s; killed'
        self.log.close()
        return problem


def default_targets(calibration: Path) -> Dict[str, List[str]]:
    """Return the built-in targets: the node, ``node_full``, ``node_nocov`` and ``node_stock``
    (when the node exists; their calibration file is written to ``calibration``), the relay and
    the fast relay."""
    python = sys.executable
    targets = {}
    node = None
    if shutil.which('propagation_node'):
        node = ['propagation_node'] + NODE_ARGS
    elif (REPO / 'rigid_body_attitude' / 'ros' / 'serve.py').exists():
        node = [python, '-m', 'rigid_body_attitude.ros.serve'] + NODE_ARGS
    if node is not None:
        calibration.write_text(CALIBRATION)
        full = node + ['-p', f'mount_rpy:={FULL_NODE_MOUNT_RPY}',
                       '-p', f'calibration_file:={calibration}']
        targets.update(node=node, node_full=full,
                       node_nocov=full + ['-p', 'covariance:=false'],
                       # the attitude filter: the imu_filter scene on the same front end
                       node_filter=full + ['-p', 'scene:=imu_filter'],
                       # the default node served by rclpy's stock executor (its fallback)
                       node_stock=['env', 'RIGID_BODY_ATTITUDE_STOCK_EXECUTOR=1'] + node)
    targets['relay'] = [python, str(BENCH / 'relay.py')]
    targets['fast_relay'] = [python, str(BENCH / 'fast_relay.py')]
    return targets


class Session:
    """Starts processes for one run and guarantees they are all stopped afterwards."""

    def __init__(self, domain_id: int, depth: int, workdir: Path) -> None:
        """Use ``domain_id`` and queue ``depth`` everywhere; logs and data go to ``workdir``."""
        self.env = ros_env(domain_id)
        self.env['BENCH_QUEUE_DEPTH'] = str(depth)
        self.env['PYTHONPATH'] = os.pathsep.join(
            [str(REPO)] + [p for p in [os.environ.get('PYTHONPATH')] if p])
        self.workdir = workdir
        self.processes: List[Process] = []

    def start(self, name: str, argv: List[str], json_stdout: bool = False,
              extra_env: Optional[Dict[str, str]] = None) -> Process:
        """Start ``argv`` (environment plus ``extra_env``) with its log in
        ``workdir/name.log``."""
        process = Process(argv, {**self.env, **(extra_env or {})}, self.workdir / f'{name}.log',
                          json_stdout)
        self.processes.append(process)
        return process

    def close(self) -> List[str]:
        """Stop every process still running (SIGINT, then SIGKILL); return the problems."""
        problems = [process.stop() for process in reversed(self.processes)]
        self.processes.clear()
        return [problem for problem in problems if problem]


def endpoint_environment(profile: str) -> Dict[str, str]:
    """The Fast DDS profile of the bench's own publisher and subscriber: the package's
    ``config/fastdds.xml`` by default, as ``docs/tuning.md`` tells users to give the processes
    that talk to the node; ``none`` = Fast DDS's defaults."""
    if profile == 'none':
        return {}
    from rigid_body_attitude.ros.middleware import FASTDDS_PROFILE_VARIABLES
    return {variable: profile for variable in FASTDDS_PROFILE_VARIABLES}


#: The package's Fast DDS profile, the default of every bench process that talks to the node.
PACKAGE_PROFILE = str(REPO / 'config' / 'fastdds.xml')


def add_endpoint_profile_argument(parser: argparse.ArgumentParser) -> None:
    """``--endpoint-profile`` (:func:`endpoint_environment`), for every script that starts the
    bench's publisher and subscriber with :func:`start_processes`."""
    parser.add_argument('--endpoint-profile', default=PACKAGE_PROFILE,
                        help='Fast DDS profile of the bench publisher and subscriber (default '
                        'the package\'s; "none" = Fast DDS defaults); targets keep their own')


def start_processes(session: Session, target_argv: List[str], rate: float, duration: float,
                    warmup: float, args: argparse.Namespace) -> Dict[str, Process]:
    """Start subscriber, target and publisher; return once the publisher is matched."""
    python = sys.executable
    endpoint_env = endpoint_environment(args.endpoint_profile)
    subscriber = session.start('subscriber', [
        python, str(BENCH / '_subscriber.py'), '--out', str(session.workdir / 'poses.bin')],
        json_stdout=True, extra_env=endpoint_env)
    target = session.start('target', target_argv)
    subscriber.wait_event('matched', args.match_timeout, watch=[target])
    publisher = session.start('publisher', [
        python, str(BENCH / '_publisher.py'), '--rate', str(rate), '--duration', str(duration),
        '--warmup', str(warmup), '--gyro', args.imu_gyro, '--accel', args.imu_accel,
        '--mag-every', str(args.mag_every)],
        json_stdout=True, extra_env=endpoint_env)
    publisher.wait_event('matched', args.match_timeout, watch=[target])
    return {'target': target, 'publisher': publisher, 'subscriber': subscriber}


def counted_poses(session: Session, subscriber: Process, end: dict, drain: float
                  ) -> Tuple['np.ndarray', 'np.ndarray']:
    """Stop the subscriber; return the stamps and receive times (ns) of the poses that count.

    A pose counts if its stamp lies in the publisher's measured window and it arrived at most
    ``drain`` seconds after the last publish.
    """
    import numpy as np
    subscriber.stop(signal.SIGTERM, grace=10.0)
    data = np.fromfile(session.workdir / 'poses.bin', dtype='<i8')
    stamps, received_at = data[:data.size // 2], data[data.size // 2:]
    counted = ((stamps >= end['first_stamp_ns']) & (stamps <= end['last_stamp_ns'])
               & (received_at <= end['last_stamp_ns'] + int(drain * 1e9)))
    return stamps[counted], received_at[counted]


def delivery_summary(stamps: 'np.ndarray', arrivals: 'np.ndarray', latency_ms: 'np.ndarray',
                     end: dict) -> dict:
    """Counts and latencies (``latency_ms``, :func:`latencies_ms`) of the counted poses
    (:func:`counted_poses`).

    ``latency_max_at_s``: when the slowest counted pose was stamped, in seconds after the
    window's first stamp; ``receive_gap_max_ms``: the longest time without a counted pose
    arriving (the node sent nothing, or nothing got through).
    """
    import numpy as np
    received = int(np.unique(stamps).size)

    def percentile(q: float) -> Optional[float]:
        return float(np.percentile(latency_ms, q)) if received else None
    worst_at_s = (float(stamps[np.argmax(latency_ms)] - end['first_stamp_ns']) * 1e-9
                  if received else None)
    gap_ms = float(np.diff(np.sort(arrivals)).max() * 1e-6) if arrivals.size > 1 else None
    return {'sent': end['sent'], 'received': received, 'lost': end['sent'] - received,
            'latency_p50_ms': percentile(50), 'latency_p99_ms': percentile(99),
            'latency_max_ms': percentile(100), 'latency_max_at_s': worst_at_s,
            'receive_gap_max_ms': gap_ms}


def latencies_ms(stamps: 'np.ndarray', times: 'np.ndarray') -> 'np.ndarray':
    """Milliseconds from each pose's stamp to its arrival."""
    return (times - stamps) * 1e-6


def measure(session: Session, target_argv: List[str], rate: float,
            args: argparse.Namespace) -> dict:
    """Run one target at one rate and return its row (counts, CPU, latency, RSS)."""
    processes = start_processes(session, target_argv, rate, args.duration, args.warmup, args)
    publisher, target = processes['publisher'], processes['target']
    pids = {name: process.popen.pid for name, process in processes.items()}
    publisher.wait_event('start', args.match_timeout + args.warmup + 5, watch=[target])
    threads0 = thread_run_ns(pids['target'])
    seconds0 = {name: cpu_seconds(pid) for name, pid in pids.items()}
    machine0, wall0 = process_ticks(), time.monotonic()
    end = publisher.wait_event('end', 2 * args.duration + 10, watch=[target])
    seconds1 = {name: cpu_seconds(pid) for name, pid in pids.items()}
    machine1, window_s = process_ticks(), time.monotonic() - wall0
    threads1 = thread_run_ns(pids['target'])
    rss = rss_kib(target.popen.pid)
    time.sleep(args.drain)
    target.check_alive()
    cpu = {name: 100.0 * (seconds1[name] - seconds0[name]) / window_s for name in pids}
    ours = set(pids.values()) | {os.getpid()}
    other_cores = other_load_ticks(machine0, machine1, ours) / CLOCK_TICKS / window_s
    stamps, arrivals = counted_poses(session, processes['subscriber'], end, args.drain)
    latency_ms = latencies_ms(stamps, arrivals)
    return {
        'rate_hz': rate, **delivery_summary(stamps, arrivals, latency_ms, end),
        '_latency_ms': latency_ms,
        'publisher_hz': end['achieved_hz'], 'publisher_max_lag_ms': end['max_lag_ms'],
        'cpu_percent': cpu['target'], 'publisher_cpu_percent': cpu['publisher'],
        'subscriber_cpu_percent': cpu['subscriber'], 'other_load_cores': other_cores,
        'rss_kib': rss,
        'cpu_by_thread': cpu_by_thread_name(threads0, threads1, window_s),
    }


def display(argv: List[str]) -> str:
    """Return ``argv`` as a command line with this interpreter as ``python``, paths relative."""
    words = ['python' if word == sys.executable else word for word in argv]
    return shlex.join(words).replace(f'{REPO}/', '')


def run_throughput(targets: Dict[str, List[str]], args: argparse.Namespace) -> dict:
    """Measure every target at every rate in ``--repeats`` interleaved windows; return the
    results document (one pooled row per target and rate, :func:`pooled_row`)."""
    results = {'machine': _report.machine_description(), 'duration_s': args.duration,
               'warmup_s': args.warmup, 'drain_s': args.drain, 'depth': args.depth,
               'repeats': args.repeats, 'cpu_clock': 'schedstat_ns',
               'invocation': display([sys.executable] + sys.argv),
               'targets': {label: {'command': display(argv), 'rows': []}
                           for label, argv in targets.items()}}
    problems = results['problems'] = []
    labels = list(targets)
    for rate in args.rates:
        windows: Dict[str, List[dict]] = {label: [] for label in labels}
        for window in range(args.repeats):
            shift = window % len(labels) if labels else 0
            for label in labels[shift:] + labels[:shift]:  # no target always goes first
                suffix = f'_w{window + 1}' if args.repeats > 1 else ''
                row = run_window(targets[label], rate, args, problems,
                                 f'{label}_{rate:.0f}{suffix}')
                if row is not None:
                    windows[label].append(row)
                    print(_report.row_line(label + suffix, row), flush=True)
        for label in labels:
            if windows[label]:
                pooled = pooled_row(windows[label])
                results['targets'][label]['rows'].append(pooled)
                if args.repeats > 1:
                    print(_report.row_line(f'{label} pooled', pooled), flush=True)
    for problem in problems:
        print(f'error: {problem}', file=sys.stderr)
    return results


def run_window(argv: List[str], rate: float, args: argparse.Namespace, problems: List[str],
               name: str) -> Optional[dict]:
    """One window of one target at one rate in fresh processes (:func:`measure`); a crash
    or a process that had to be killed goes to ``problems`` as ``name: ...``."""
    with tempfile.TemporaryDirectory(prefix='bench_') as tmp:
        session = Session(args.domain_id, args.depth, Path(tmp))
        row = None
        try:
            row = measure(session, argv, rate, args)
        except ProcessCrashed as err:
            problems.append(f'{name}: {err}')
        finally:
            problems.extend(f'{name}: {problem}' for problem in session.close())
    return row


def pooled_row(windows: List[dict]) -> dict:
    """One row from the windows of one target at one rate.

    Counts are summed; latency percentiles are those of all counted poses of all windows
    together (``latency_max_window``: the window, from 1, with the slowest pose); CPU figures
    are the median window's (with an even count the mean of the two middle ones), the thread
    breakdown that of the window with the median target CPU; the publisher's rate is the lowest
    window's, its lag, the receive gap, the other load and the RSS the highest. Each window's
    own row is kept under ``windows``. A single window is returned as it is.
    """
    import numpy as np
    latencies = [window.pop('_latency_ms') for window in windows]
    if len(windows) == 1:
        return windows[0]
    pooled_ms = np.concatenate(latencies)

    def percentile(q: float) -> Optional[float]:
        return float(np.percentile(pooled_ms, q)) if pooled_ms.size else None

    def median(key: str) -> float:
        return float(np.median([window[key] for window in windows]))

    def highest(key: str) -> Optional[float]:
        values = [window[key] for window in windows if window[key] is not None]
        return max(values) if values else None
    by_cpu = sorted(range(len(windows)), key=lambda index: windows[index]['cpu_percent'])
    slowest = max(range(len(windows)), key=lambda index: windows[index]['latency_max_ms'] or -1.0)
    return {
        'rate_hz': windows[0]['rate_hz'],
        **{key: sum(window[key] for window in windows) for key in ('sent', 'received', 'lost')},
        'latency_p50_ms': percentile(50), 'latency_p99_ms': percentile(99),
        'latency_max_ms': percentile(100),
        'latency_max_at_s': windows[slowest]['latency_max_at_s'],
        'latency_max_window': slowest + 1,
        'receive_gap_max_ms': highest('receive_gap_max_ms'),
        'publisher_hz': min(window['publisher_hz'] for window in windows),
        'publisher_max_lag_ms': highest('publisher_max_lag_ms'),
        **{key: median(key) for key in ('cpu_percent', 'publisher_cpu_percent',
                                        'subscriber_cpu_percent')},
        'other_load_cores': highest('other_load_cores'), 'rss_kib': highest('rss_kib'),
        'cpu_by_thread': windows[by_cpu[(len(windows) - 1) // 2]]['cpu_by_thread'],
        'windows': windows,
    }


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rates', default=','.join(map(str, DEFAULT_RATES)),
                        help='comma-separated rates in Hz (default %(default)s)')
    parser.add_argument('--duration', type=float, default=4.0,
                        help='measured seconds per rate (default %(default)s)')
    parser.add_argument('--repeats', type=int, default=1,
                        help='windows per target and rate, interleaved (target order rotated '
                             'each window); rows pool them (default %(default)s)')
    parser.add_argument('--warmup', type=float, default=0.5,
                        help='unmeasured seconds of publishing first (default %(default)s)')
    parser.add_argument('--drain', type=float, default=1.0,
                        help='seconds after the last publish a pose may still arrive '
                             '(default %(default)s)')
    parser.add_argument('--targets', default=None,
                        help='comma-separated built-in targets: node, node_full, node_nocov, '
                             'node_filter, node_stock, relay, fast_relay (default: node, relay, '
                             'fast_relay; '
                             '"none": only the --target ones)')
    parser.add_argument('--target', action='append', default=[], metavar='LABEL=COMMAND',
                        help='an extra target command line (repeatable)')
    parser.add_argument('--node-cmd', default=None,
                        help='command line of the node target (default: propagation_node '
                             'or python -m rigid_body_attitude.ros.serve, with '
                             f'{" ".join(NODE_ARGS)})')
    parser.add_argument('--imu-gyro', default='0.1,-0.2,0.3',
                        help='angular_velocity of the published Imu [rad/s] (default '
                             '%(default)s)')
    parser.add_argument('--imu-accel', default='0,0,0',
                        help='linear_acceleration of the published Imu [m/s^2]; zeros (the '
                             'default) = no accelerometer data, gravity = the node levels '
                             'in the warm-up (with --imu-gyro under 0.05 rad/s)')
    parser.add_argument('--mag-every', type=int, default=0,
                        help='also publish a MagneticField on imu/mag with every N-th Imu '
                             '(node_filter; 0: none, the default)')
    parser.add_argument('--depth', type=int, default=QUEUE_DEPTH,
                        help='KEEP_LAST depth of the publisher, subscriber and relays '
                             '(default %(default)s)')
    parser.add_argument('--domain-id', type=int,
                        default=int(os.environ.get('ROS_DOMAIN_ID', '64')))
    parser.add_argument('--match-timeout', type=float, default=30.0)
    parser.add_argument('--json', type=Path, default=None,
                        help='also write the results document (JSON) here')
    add_endpoint_profile_argument(parser)
    parser.add_argument('--report', type=Path, default=None,
                        help='write the Markdown summary here instead of printing it')
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f'expected --repeats >= 1, got {args.repeats}')
    args.rates = [float(rate) for rate in args.rates.split(',') if rate]
    return args


def select_targets(args: argparse.Namespace, folder: Path) -> Dict[str, List[str]]:
    """Return the targets to measure, in order, from the built-ins (files they need go to
    ``folder``) and ``--target``."""
    available = default_targets(folder / 'calibration.yaml')
    if args.node_cmd:
        available['node'] = shlex.split(args.node_cmd)
    if args.targets == 'none':
        names = []
    else:
        names = (args.targets.split(',') if args.targets
                 else [name for name in DEFAULT_TARGETS if name in available])
    missing = [name for name in names if name not in available]
    if missing:
        raise SystemExit(f'error: targets {missing} not available; have {list(available)}')
    targets = {name: available[name] for name in names}
    for spec in args.target:
        label, _, command = spec.partition('=')
        if not label or not command:
            raise SystemExit(f'error: expected --target LABEL=COMMAND, got {spec!r}')
        targets[label] = shlex.split(command)
    return targets


def main(argv: Optional[List[str]] = None) -> int:
    """Run the sweep and write its summary (stdout or ``--report``) and, if asked, its JSON."""
    args = parse_args(argv)
    with tempfile.TemporaryDirectory(prefix='bench_targets_') as folder:
        targets = select_targets(args, Path(folder))
        try:
            result = run_throughput(targets, args)
        except ProcessCrashed as err:
            print(f'error: {err}', file=sys.stderr)
            return 1
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=1))
    _report.write(result, args.report)
    return 1 if result.get('problems') else 0


if __name__ == '__main__':
    sys.exit(main())
