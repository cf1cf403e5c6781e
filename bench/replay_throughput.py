"""Replay throughput: gyro messages per second through ``replay``, end to end and per stage.

Writes a synthetic strapdown bag (``sensor_msgs/Imu`` on ``imu`` at 1 kHz, a slowly varying
rate) and measures, best of ``--repeat`` runs:

* **end to end** — :func:`rigid_body_attitude.replay.replay_bag` as the ``replay`` command runs
  it (read, decode, stream rules + propagator, published values, encode, write), for the
  node's full output set (orientation, pose, imu/data per sample; energy and momentum at
  50 Hz; diagnostics at 1 Hz) and for ``orientation`` only, with sqlite3 and MCAP storage;
* **per stage**, the same work split up, each timed alone over all messages: read the bag,
  decode the header stamp and rate, ``GyroStream.add`` (stream rules + propagator),
  ``OutputTracker.attitude``, encode orientation + pose + imu/data, and write three records;
  then the sum without bag I/O (decode, propagate, encode: the issue's throughput definition)
  and the sum of all stages. For reference, the bare exp-map step in plain floats
  (``quaternion.scalar_exp_step``, no stream rules): what the propagator's arithmetic costs.

Usage: ``python bench/replay_throughput.py [--messages 200000] [--repeat 3]``. The machine is
shared: run it when it is otherwise idle and read the best run.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rigid_body_attitude.bag import (
    BagReader, BagWriter, encode_pose_stamped, encode_quaternion_stamped, header_stamp_ns,
    imu_rates, write_bag)
from rigid_body_attitude.messages import TimeBase
from rigid_body_attitude.outputs import OutputTracker
from rigid_body_attitude.propagator import build_propagator
from rigid_body_attitude.quaternion import scalar_exp_step
from rigid_body_attitude.replay import ReplayOptions, replay_bag
from rigid_body_attitude.bag import imu_with_orientation as _imu_with_orientation
from rigid_body_attitude.scene import load_scene
from rigid_body_attitude.stream import GyroStream

RATE_HZ = 1000.0


def make_bag(path: Path, count: int, storage: str) -> None:
    """``count`` Imu messages at 1 kHz with a smoothly varying body rate."""
    stamps = 1_000.0 + np.arange(count) / RATE_HZ
    phase = np.arange(count) / RATE_HZ
    rates = np.stack([0.3 * np.sin(phase), -0.2 + 0.1 * np.cos(2 * phase),
                      0.5 * np.sin(0.5 * phase)], axis=1)
    write_bag(path, stamps=stamps, rates=rates, storage=storage)


def best_of(repeat: int, run: Callable[[], None]) -> float:
    """Shortest wall time of ``repeat`` runs [s]."""
    times = []
    for _ in range(repeat):
        begin = time.perf_counter()
        run()
        times.append(time.perf_counter() - begin)
    return min(times)


def end_to_end(bag: Path, workdir: Path, outputs: tuple[str, ...], storage: str,
               repeat: int) -> float:
    """Best wall time of ``replay_bag`` (including opening and closing both bags)."""
    def run() -> None:
        out = workdir / 'out'
        shutil.rmtree(out, ignore_errors=True)
        replay_bag(bag, out, ReplayOptions(scene='strapdown', outputs=outputs,
                                           storage=storage), keep_series=False)
    return best_of(repeat, run)


def stages(bag: Path, workdir: Path, repeat: int) -> dict[str, float]:
    """Best wall time of each stage over all messages of the bag [s]."""
    with BagReader(bag) as reader:
        messages = list(reader.messages(['imu']))
    times: dict[str, float] = {}

    def read() -> None:
        with BagReader(bag) as reader:
            for _ in reader.messages(['imu']):
                pass
    times['read bag'] = best_of(repeat, read)

    decoded: list[tuple[int, tuple[float, ...]]] = []

    def decode() -> None:
        decoded.clear()
        for _, _, _, data in messages:
            decoded.append((header_stamp_ns(data), imu_rates(data)[1]))
    times['decode stamp + rate'] = best_of(repeat, decode)

    scene = load_scene('strapdown')

    def propagate() -> None:
        propagator = build_propagator(scene)
        stream = GyroStream(propagator, 0.1, 1.0)
        seconds = TimeBase().seconds
        add = stream.add
        for stamp_ns, omega in decoded:
            sec, nanosec = divmod(stamp_ns, 1_000_000_000)
            add(seconds(sec, nanosec), omega)
    times['GyroStream.add (core)'] = best_of(repeat, propagate)

    def plain_step() -> None:
        q = (1.0, 0.0, 0.0, 0.0)
        dt = 1.0 / RATE_HZ
        for _, omega in decoded:
            q = scalar_exp_step(q, omega, dt)
    times['reference: exp step in plain floats'] = best_of(repeat, plain_step)

    propagator = build_propagator(scene)

    def attitude() -> None:
        tracker = OutputTracker()
        for _ in decoded:
            tracker.attitude(propagator)
    times['OutputTracker.attitude (core)'] = best_of(repeat, attitude)

    q = (0.5, 0.5, 0.5, 0.5)
    encoded: list[tuple[bytes, bytes, bytes]] = []

    def encode() -> None:
        encoded.clear()
        for (stamp_ns, _), (_, _, _, data) in zip(decoded, messages):
            encoded.append((encode_quaternion_stamped(stamp_ns, 'world', q),
                            encode_pose_stamped(stamp_ns, 'world', (0.0, 0.0, 0.0), q),
                            _imu_with_orientation(data, q)))
    times['encode 3 outputs'] = best_of(repeat, encode)

    def write() -> None:
        out = workdir / 'write'
        shutil.rmtree(out, ignore_errors=True)
        with BagWriter(out) as writer:
            connections = [writer.add_topic('orientation', 'geometry_msgs/msg/QuaternionStamped'),
                           writer.add_topic('pose', 'geometry_msgs/msg/PoseStamped'),
                           writer.add_topic('imu/data', 'sensor_msgs/msg/Imu')]
            for (_, bag_ns, _, _), records in zip(messages, encoded):
                for connection, data in zip(connections, records):
                    writer.write(connection, bag_ns, data)
    times['write 3 records (sqlite3)'] = best_of(repeat, write)
    return times


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print a table of messages per second."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--messages', type=int, default=200_000)
    parser.add_argument('--repeat', type=int, default=3)
    args = parser.parse_args(argv)
    workdir = Path(tempfile.mkdtemp(prefix='replay_bench_'))
    try:
        count = args.messages
        print(f'{count} Imu messages at 1 kHz; best of {args.repeat} runs; msgs/s = gyro '
              f'messages per second of wall time')
        print(f'{"end to end (replay_bag)":48s} {"s":>8s} {"msgs/s":>10s}')
        for storage in ('sqlite3', 'mcap'):
            bag = workdir / f'in_{storage}'
            make_bag(bag, count, storage)
            for label, outputs in (('all node outputs', ()), ('orientation only',
                                                              ('orientation',))):
                seconds = end_to_end(bag, workdir, outputs, storage, args.repeat)
                print(f'  {storage:7s} {label:38s} {seconds:8.3f} {count / seconds:10,.0f}')
        print(f'{"per stage (sqlite3 input)":48s} {"s":>8s} {"msgs/s":>10s} {"µs/msg":>8s}')
        times = stages(workdir / 'in_sqlite3', workdir, args.repeat)
        for name, seconds in times.items():
            print(f'  {name:46s} {seconds:8.3f} {count / seconds:10,.0f} '
                  f'{seconds / count * 1e6:8.2f}')
        without_io = sum(seconds for name, seconds in times.items()
                         if not name.startswith(('read', 'write', 'reference')))
        stages_total = sum(seconds for name, seconds in times.items()
                           if not name.startswith('reference'))
        for name, total in (('decode + propagate + encode (no bag I/O)', without_io),
                            ('sum of the stages', stages_total)):
            print(f'  {name:46s} {total:8.3f} {count / total:10,.0f} '
                  f'{total / count * 1e6:8.2f}')
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
