"""Replay throughput: gyro messages per second through ``replay``, end to end and per stage.

Writes a synthetic strapdown bag (``sensor_msgs/Imu`` on ``imu`` at 1 kHz, a slowly varying
rate) and measures, best of ``--repeat`` runs, both wall time and the process's CPU time (on a
shared machine the CPU time is the steadier figure; the wall time is what a user waits):

* **end to end** — :func:`rigid_body_attitude.tools.replay.replay_bag` as the ``replay`` command
  runs it (read, decode, stream rules + propagator, published values, encode, write, including
  opening and closing both bags), for the node's full output set (orientation, pose, imu/data
  per sample; energy and momentum at 50 Hz; diagnostics at 1 Hz) and for ``orientation``
  only, with sqlite3 and MCAP storage (input and output in the same storage);
* **per stage**, the same work split up, each timed alone over all messages (CPU time): read
  the bag (sqlite3, MCAP), decode with the node's Imu decoder
  (:mod:`rigid_body_attitude.session.decoding`: stamp, frame id, rate), ``GyroStream.add``
  (stream rules + propagator, core), ``GyroSession.gyro`` (the session's per-sample work:
  stamp checks, ``GyroStream.add``, the attitude; into a sink that drops it),
  ``OutputTracker.attitude`` (core), encode orientation + pose + imu/data (the replay's
  per-frame encoders), and write the three
  records per message with ``BagWriter.write_many`` (sqlite3, MCAP) and, for comparison, one
  ``BagWriter.write`` call per record; then the sum decode + propagate + encode (no bag I/O)
  and the sums of the stages with each storage. For reference, the bare exp-map step in
  plain floats (``quaternion.scalar_exp_step``, no stream rules): what the propagator's
  arithmetic costs.

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

from rigid_body_attitude.bag import BagReader, BagWriter, write_bag
from rigid_body_attitude.core.propagator import build_propagator
from rigid_body_attitude.core.quaternion import scalar_exp_step
from rigid_body_attitude.core.scene import load_scene
from rigid_body_attitude.msgs import (
    IMU, POSE_STAMPED, QUATERNION_STAMPED, imu_with_orientation, pose_stamped_encoder,
    quaternion_stamped_encoder)
from rigid_body_attitude.session import decoding
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.outputs import OutputSample, OutputTracker
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.reports import DiagnosticReport
from rigid_body_attitude.session.stream import GyroStream
from rigid_body_attitude.tools.replay import ReplayOptions, replay_bag

RATE_HZ = 1000.0
STORAGES = ('sqlite3', 'mcap')
OUTPUT_TYPES = {'orientation': QUATERNION_STAMPED, 'pose': POSE_STAMPED, 'imu/data': IMU}


def make_bag(path: Path, count: int, storage: str) -> None:
    """``count`` Imu messages at 1 kHz with a smoothly varying body rate."""
    stamps = 1_000.0 + np.arange(count) / RATE_HZ
    phase = np.arange(count) / RATE_HZ
    rates = np.stack([0.3 * np.sin(phase), -0.2 + 0.1 * np.cos(2 * phase),
                      0.5 * np.sin(0.5 * phase)], axis=1)
    write_bag(path, stamps=stamps, rates=rates, storage=storage)


class NullSink:
    """An output sink that drops everything (to time the session alone)."""

    def attitude(self, sec: int, nanosec: int, attitude: tuple[float, ...],
                 imu: bytes | None) -> None:
        """Drop."""

    def dynamics(self, sec: int, nanosec: int, sample: OutputSample,
                 velocity_body: tuple[float, ...]) -> None:
        """Drop."""

    def wants_invariants(self) -> bool:
        """No."""
        return False

    def invariants(self, sec: int, nanosec: int, energy: float,
                   world_momentum: tuple[float, ...]) -> None:
        """Drop."""

    def diagnostics(self, report: DiagnosticReport) -> None:
        """Drop."""

    def log(self, level: int, text: str) -> None:
        """Drop."""


def best_of(repeat: int, run: Callable[[], None]) -> tuple[float, float]:
    """Shortest wall time and shortest CPU time of ``repeat`` runs [s]."""
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        run()
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
    return min(walls), min(cpus)


def end_to_end(bag: Path, workdir: Path, outputs: tuple[str, ...], storage: str,
               repeat: int) -> tuple[float, float]:
    """Best wall and CPU time of ``replay_bag`` (including opening and closing both bags)."""
    def run() -> None:
        out = workdir / 'out'
        shutil.rmtree(out, ignore_errors=True)
        replay_bag(bag, out, ReplayOptions(scene='strapdown', outputs=outputs,
                                           storage=storage), keep_series=False)
    return best_of(repeat, run)


def _write_stage(workdir: Path, storage: str, records: list[tuple[int, int, bytes]],
                 batched: bool) -> Callable[[], None]:
    """Write the three outputs of every message, in batches as the replay does, or singly."""
    def write() -> None:
        out = workdir / 'write'
        shutil.rmtree(out, ignore_errors=True)
        with BagWriter(out, storage=storage) as writer:
            connections = writer.add_topics(OUTPUT_TYPES)
            if batched:
                for begin in range(0, len(records), 3 * 4096):
                    writer.write_many(records[begin:begin + 3 * 4096])
                return
            by_id = {connection.id: connection for connection in connections.values()}
            for connection_id, bag_time_ns, data in records:
                writer.write(by_id[connection_id], bag_time_ns, data)
    return write


def stages(workdir: Path, repeat: int) -> dict[str, float]:
    """Best CPU time of each stage over all messages of the bags [s]."""
    times: dict[str, float] = {}
    for storage in STORAGES:
        def read(storage: str = storage) -> None:
            with BagReader(workdir / f'in_{storage}') as reader:
                for _ in reader.messages(['imu']):
                    pass
        times[f'read bag ({storage})'] = best_of(repeat, read)[1]
    with BagReader(workdir / 'in_sqlite3') as reader:
        messages = list(reader.messages(['imu']))
    decoded: list[tuple[int, int, tuple[float, ...]]] = []

    def decode() -> None:
        decoded.clear()
        for _, _, _, data in messages:
            sec, nanosec, _, rate, _ = decoding.imu(data)
            decoded.append((sec, nanosec, rate))
    times['decode (the node\'s Imu decoder)'] = best_of(repeat, decode)[1]

    scene = load_scene('strapdown')

    def propagate() -> None:
        stream = GyroStream(build_propagator(scene), 0.1, 1.0)
        add = stream.add
        for sec, nanosec, omega in decoded:
            add(sec * 1_000_000_000 + nanosec, omega)
    times['GyroStream.add (core)'] = best_of(repeat, propagate)[1]

    def session() -> None:
        gyro = GyroSession(scene, defaults(), NullSink(), int, float).gyro
        for sec, nanosec, omega in decoded:
            gyro(sec, nanosec, omega)
    times['GyroSession.gyro (session, null sink)'] = best_of(repeat, session)[1]

    def plain_step() -> None:
        q = (1.0, 0.0, 0.0, 0.0)
        dt = 1.0 / RATE_HZ
        for _, _, omega in decoded:
            q = scalar_exp_step(q, omega, dt)
    times['reference: exp step in plain floats'] = best_of(repeat, plain_step)[1]

    propagator = build_propagator(scene)

    def attitude() -> None:
        tracker = OutputTracker()
        for _ in decoded:
            tracker.attitude(propagator)
    times['OutputTracker.attitude (core)'] = best_of(repeat, attitude)[1]

    q = (0.5, 0.5, 0.5, 0.5)
    zero = (0.0, 0.0, 0.0)
    encode_orientation = quaternion_stamped_encoder('world')
    encode_pose = pose_stamped_encoder('world')
    records: list[tuple[int, int, bytes]] = []

    def encode() -> None:
        records.clear()
        record = records.append
        for (sec, nanosec, _), (_, bag_time_ns, _, data) in zip(decoded, messages):
            record((1, bag_time_ns, encode_orientation(sec, nanosec, q)))
            record((2, bag_time_ns, encode_pose(sec, nanosec, zero, q)))
            record((3, bag_time_ns, imu_with_orientation(data, q)))
    times['encode 3 outputs'] = best_of(repeat, encode)[1]

    for storage in STORAGES:
        times[f'write 3 records, write_many ({storage})'] = best_of(
            repeat, _write_stage(workdir, storage, records, batched=True))[1]
    for storage in STORAGES:
        times[f'reference: 3 single writes ({storage})'] = best_of(
            repeat, _write_stage(workdir, storage, records, batched=False))[1]
    return times


def _row(name: str, seconds: float, count: int) -> str:
    return (f'  {name:46s} {seconds:8.3f} {count / seconds:10,.0f} '
            f'{seconds / count * 1e6:8.2f}')


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
              f'messages per second')
        print(f'{"end to end (replay_bag)":48s} {"wall s":>8s} {"msgs/s":>10s} '
              f'{"CPU s":>8s} {"msgs/s":>10s}')
        for storage in STORAGES:
            bag = workdir / f'in_{storage}'
            make_bag(bag, count, storage)
            for label, outputs in (('all node outputs', ()), ('orientation only',
                                                              ('orientation',))):
                wall, cpu = end_to_end(bag, workdir, outputs, storage, args.repeat)
                print(f'  {storage:7s} {label:38s} {wall:8.3f} {count / wall:10,.0f} '
                      f'{cpu:8.3f} {count / cpu:10,.0f}')
        print(f'{"per stage (CPU time)":48s} {"s":>8s} {"msgs/s":>10s} {"µs/msg":>8s}')
        times = stages(workdir, args.repeat)
        for name, seconds in times.items():
            print(_row(name, seconds, count))
        core = ('decode (the node\'s Imu decoder)', 'GyroSession.gyro (session, null sink)',
                'encode 3 outputs')
        without_io = sum(times[name] for name in core)
        print(_row('decode + propagate + encode (no bag I/O)', without_io, count))
        for storage in STORAGES:
            total = without_io + times[f'read bag ({storage})'] + times[
                f'write 3 records, write_many ({storage})']
            print(_row(f'sum of the stages ({storage})', total, count))
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
