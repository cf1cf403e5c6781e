"""Benchmark helper: every thread's run and wait time, sampled through a window.

``node_throughput.py --sample-threads MS`` starts a :class:`ThreadSampler` on the target, the
publisher and the subscriber for each measured window. Every ``MS`` milliseconds it reads each
thread's ``/proc/<pid>/task/<tid>/schedstat`` (run time and run-queue wait time in ns, kept
open and re-read with ``pread``: about 2 µs a file) and notes its own wake-up time, so its own
lateness is a probe of the whole machine (a sampler several ms late while the bench publisher
is late too is a stall of the machine, not of the target). With each sample it also reads every
CPU's idle, iowait, irq, softirq and steal time from ``/proc/stat`` (cumulative; the kernel
keeps them in ns and prints them in 10 ms ticks). *Steal* is the time the hypervisor ran
something else on that virtual CPU while the guest wanted it (this Firecracker guest's kernel
accounts it, through kvm's steal-time page). Where cpuidle is present it also reads each
CPU's time in its idle states (``/sys/devices/system/cpu/cpuN/cpuidle/state*/time``, in µs),
the precise idle time. At the end it writes ``threads.npz``: ``t_ns`` (CLOCK_REALTIME, the
clock of the pose stamps), ``run_ns`` and ``wait_ns`` (samples × threads, cumulative), each
thread's ``process`` and ``name``, ``cpu_ns`` (samples × CPUs × :data:`CPU_FIELDS`,
cumulative, 10 ms steps) and, with cpuidle, ``cpuidle_ns`` (samples × CPUs, cumulative).
``bench/episodes.py`` reads these beside the poses to explain a window's slow spells.
"""

from __future__ import annotations

import os
from pathlib import Path
import threading
import time
from typing import Dict, List, Tuple

import numpy as np

from _common import thread_run_ns

#: Samples kept at most (a 4 s window at 5 ms needs 800).
MAX_SAMPLES = 20000

#: The per-CPU fields of ``/proc/stat`` kept in ``cpu_ns``, by their column (after the name).
CPU_FIELDS = {'idle': 3, 'iowait': 4, 'irq': 5, 'softirq': 6, 'steal': 7}

#: Nanoseconds per ``/proc/stat`` tick (USER_HZ).
TICK_NS = 1_000_000_000 // os.sysconf('SC_CLK_TCK')


def _open_cpuidle(cpus: int) -> List[List[int]]:
    """Per CPU, open fds of its idle states' ``time`` files (none without cpuidle)."""
    states = [sorted(Path(f'/sys/devices/system/cpu/cpu{cpu}/cpuidle').glob('state*/time'))
              for cpu in range(cpus)]
    if not all(states):
        return []
    return [[os.open(state, os.O_RDONLY) for state in cpu_states] for cpu_states in states]


def cpu_times_ns(text: bytes) -> List[List[int]]:
    """Each CPU's :data:`CPU_FIELDS` in ns from the text of ``/proc/stat``."""
    rows = []
    for line in text.split(b'\n')[1:]:
        if not line.startswith(b'cpu'):
            break
        values = line.split()[1:]
        rows.append([int(values[column]) * TICK_NS for column in CPU_FIELDS.values()])
    return rows


def _open_threads(pids: Dict[str, int]) -> List[Tuple[str, str, int]]:
    """(process label, thread name, open schedstat fd) of every thread of ``pids`` now."""
    threads = []
    for label, pid in pids.items():
        for task, (name, _) in sorted(thread_run_ns(pid).items()):
            try:
                fd = os.open(f'/proc/{pid}/task/{task}/schedstat', os.O_RDONLY)
            except (FileNotFoundError, ProcessLookupError):
                continue  # ended meanwhile
            threads.append((label, name, fd))
    return threads


class ThreadSampler:
    """Samples run and wait times of every thread of some processes on a thread of its own."""

    def __init__(self, pids: Dict[str, int], period_ms: float) -> None:
        """Sample the threads ``pids`` have now (label -> pid) every ``period_ms``."""
        self.period_ns = int(period_ms * 1e6)
        self.threads = _open_threads(pids)
        self.t_ns = np.zeros(MAX_SAMPLES, dtype=np.int64)
        self.run_ns = np.zeros((MAX_SAMPLES, len(self.threads)), dtype=np.int64)
        self.wait_ns = np.zeros_like(self.run_ns)
        self._stat_fd = os.open('/proc/stat', os.O_RDONLY)
        cpus = len(cpu_times_ns(os.pread(self._stat_fd, 1 << 16, 0)))
        self.cpu_ns = np.zeros((MAX_SAMPLES, cpus, len(CPU_FIELDS)), dtype=np.int64)
        self._cpuidle_fds = _open_cpuidle(cpus)
        self.cpuidle_ns = np.zeros((MAX_SAMPLES, cpus), dtype=np.int64)
        self.count = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name='thread_sampler', daemon=True)

    def start(self) -> 'ThreadSampler':
        """Begin sampling."""
        self._thread.start()
        return self

    def _run(self) -> None:
        fds = [fd for _, _, fd in self.threads]
        next_ns = time.monotonic_ns()
        while not self._stop.is_set() and self.count < MAX_SAMPLES:
            row = self.count
            self.t_ns[row] = time.time_ns()
            for column, fd in enumerate(fds):
                try:
                    run, wait = os.pread(fd, 64, 0).split()[:2]
                except OSError:  # the thread ended: its times stay where they were
                    run, wait = self.run_ns[row - 1, column], self.wait_ns[row - 1, column]
                self.run_ns[row, column], self.wait_ns[row, column] = int(run), int(wait)
            self.cpu_ns[row] = cpu_times_ns(os.pread(self._stat_fd, 1 << 16, 0))
            for cpu, state_fds in enumerate(self._cpuidle_fds):
                self.cpuidle_ns[row, cpu] = 1000 * sum(int(os.pread(fd, 32, 0))
                                                       for fd in state_fds)
            self.count += 1
            next_ns += self.period_ns
            time.sleep(max(0.0, (next_ns - time.monotonic_ns()) * 1e-9))

    def stop(self, out: Path) -> None:
        """Stop sampling, close the files and write ``out`` (``threads.npz``)."""
        self._stop.set()
        self._thread.join()
        for _, _, fd in self.threads:
            os.close(fd)
        os.close(self._stat_fd)
        for state_fds in self._cpuidle_fds:
            for fd in state_fds:
                os.close(fd)
        rows = self.count
        cpuidle = {'cpuidle_ns': self.cpuidle_ns[:rows]} if self._cpuidle_fds else {}
        np.savez_compressed(out, **cpuidle, t_ns=self.t_ns[:rows], run_ns=self.run_ns[:rows],
                            wait_ns=self.wait_ns[:rows], period_ns=self.period_ns,
                            cpu_ns=self.cpu_ns[:rows], cpu_fields=np.array(list(CPU_FIELDS)),
                            process=np.array([label for label, _, _ in self.threads]),
                            name=np.array([name for _, name, _ in self.threads]))
