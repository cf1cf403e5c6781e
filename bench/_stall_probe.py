"""Benchmark helper: run the node with a 1 ms in-process sampler that explains its stalls.

Used as the node command of ``bench/node_throughput.py``::

    python bench/node_throughput.py --rates 1000 --targets none \
        --target 'probe=python bench/_stall_probe.py --out /tmp/probe --ros-args ...'

The sampler thread wakes every millisecond and records the gyro loop's handled count, its own
lateness, every thread's innermost Python frames, and (through ``gc.callbacks``) each garbage
collection. When no gyro message was handled for ``--gap-ms`` while messages had been
arriving, it also asks gdb for every native thread's stack (``--native``). At exit it writes
the samples around the longest gap to ``OUT.json``.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
from pathlib import Path
import subprocess
import sys
import threading
import time
import traceback
from typing import Any

from rigid_body_attitude.ros import node as node_module
from rigid_body_attitude.ros import serve

SAMPLE_S = 0.001


class Probe:
    """The sampler: samples kept in memory, written at exit."""

    def __init__(self, out: Path, gap_ms: float, native: bool) -> None:
        self.out, self.gap_s, self.native = out, gap_ms * 1e-3, native
        self.loop: Any = None
        self.samples: list[tuple[float, int, float, dict[str, list[str]]]] = []
        self.collections: list[tuple[float, str, int]] = []
        self.native_stacks: list[tuple[float, str]] = []
        self.stop = threading.Event()
        gc.callbacks.append(self._on_gc)

    def _on_gc(self, phase: str, info: dict[str, int]) -> None:
        self.collections.append((time.monotonic(), phase, info['generation']))

    def _frames(self) -> dict[str, list[str]]:
        names = {thread.ident: thread.name for thread in threading.enumerate()}
        result = {}
        for ident, frame in sys._current_frames().items():
            if ident == threading.get_ident():
                continue
            stack = traceback.extract_stack(frame, limit=4)
            result[names.get(ident, str(ident))] = [
                f'{Path(entry.filename).name}:{entry.lineno} {entry.name}' for entry in stack]
        return result

    def run(self) -> None:
        last_handled, last_change = 0, time.monotonic()
        asked = False
        while not self.stop.is_set():
            due = time.monotonic() + SAMPLE_S
            time.sleep(SAMPLE_S)
            now = time.monotonic()
            handled = self.loop.handled if self.loop is not None else 0
            self.samples.append((now, handled, now - due, self._frames()))
            if handled != last_handled:
                last_handled, last_change, asked = handled, now, False
            elif (self.native and not asked and handled > 100
                  and now - last_change > self.gap_s):
                asked = True
                self._ask_gdb(now)

    def _ask_gdb(self, now: float) -> None:
        def dump() -> None:
            result = subprocess.run(
                ['gdb', '-q', '-batch', '-p', str(os.getpid()), '-ex', 'thread apply all bt 12'],
                capture_output=True, text=True, timeout=30)
            self.native_stacks.append((now, result.stdout[-60000:]))
        threading.Thread(target=dump, daemon=True).start()

    def write(self) -> None:
        times = [sample[0] for sample in self.samples]
        gaps = []
        last_change_index = 0
        for index in range(1, len(self.samples)):
            if self.samples[index][1] != self.samples[index - 1][1]:
                if self.samples[index - 1][1] > 0:
                    gaps.append((times[index] - times[last_change_index], last_change_index,
                                 index))
                last_change_index = index
        gaps.sort(reverse=True)
        windows = []
        for length, begin, end in gaps[:3]:
            window = self.samples[max(0, begin - 5):end + 5]
            windows.append({'gap_s': length, 'start': times[begin],
                            'samples': [list(sample) for sample in window]})
        lateness = sorted((sample[2], sample[0]) for sample in self.samples)[-5:]
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / f'{time.time_ns()}.json').write_text(json.dumps({
            'windows': windows, 'worst_sampler_lateness': lateness,
            'collections': self.collections[-200:], 'native': self.native_stacks,
            'start': times[0] if times else 0.0}, indent=1))


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument('--out', type=Path, required=True)
    parser.add_argument('--gap-ms', type=float, default=60.0)
    parser.add_argument('--native', action='store_true')
    args, rest = parser.parse_known_args()
    probe = Probe(args.out, args.gap_ms, args.native)
    original = node_module.AttitudePropagatorNode.gyro_loop

    def gyro_loop(self: Any, extra_timers: Any = ()) -> Any:
        probe.loop = original(self, extra_timers)
        return probe.loop

    node_module.AttitudePropagatorNode.gyro_loop = gyro_loop  # type: ignore[method-assign]
    sampler = threading.Thread(target=probe.run, name='probe', daemon=True)
    sampler.start()
    try:
        return serve.main([sys.argv[0]] + rest)
    finally:
        probe.stop.set()
        probe.write()


if __name__ == '__main__':
    sys.exit(main())
