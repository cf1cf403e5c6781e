"""Throughput of the rosbag2 layer: CDR codecs, bag reading and writing, a replay-like loop.

Prints messages per second (best of ``--repeats`` runs) for

* ``rosbags`` ``deserialize_cdr`` / ``serialize_cdr`` of ``sensor_msgs/msg/Imu`` (reference),
* the hand-written codecs of :mod:`rigid_body_attitude.bag.cdr`,
* reading a bag of Imu messages and decoding the rates (sqlite3, mcap fast path, mcap through
  ``rosbags``' iterator), writing ``QuaternionStamped`` output with :class:`BagWriter`,
* a replay-like loop: read Imu, decode, one ``scalar_exp_step``, encode and write a
  ``QuaternionStamped`` (an upper bound for ``replay``; it has no stream checks).

Usage: ``python bench/bag_codecs.py [--messages 100000] [--repeats 3]``. Bags go to a temporary
directory that is removed afterwards. The numbers depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader

from rigid_body_attitude import bag
from rigid_body_attitude.bag import cdr
from rigid_body_attitude.core.quaternion import scalar_exp_step


def best_rate(count: int, repeats: int, run: Callable[[], object]) -> float:
    """Largest ``count / seconds`` over ``repeats`` runs of ``run``."""
    best = float('inf')
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return count / best


def codec_rates(count: int, repeats: int) -> dict[str, float]:
    """Per-message codec throughput (no bag I/O)."""
    store = bag.typestore()
    data = cdr.encode_imu(1_700_000_000_000_000_000, 'base_link', (0.1, 0.2, 0.3))
    message = store.deserialize_cdr(data, bag.IMU)
    rate, attitude = (0.1, 0.2, 0.3), (1.0, 0.0, 0.0, 0.0)
    loops = range(count)
    return {
        'rosbags deserialize_cdr Imu': best_rate(count, repeats, lambda: [
            store.deserialize_cdr(data, bag.IMU) for _ in loops]),
        'rosbags serialize_cdr Imu': best_rate(count, repeats, lambda: [
            store.serialize_cdr(message, bag.IMU) for _ in loops]),
        'cdr.imu_rates (decode)': best_rate(count, repeats, lambda: [
            cdr.imu_rates(data) for _ in loops]),
        'cdr.encode_imu': best_rate(count, repeats, lambda: [
            cdr.encode_imu(5, 'base_link', rate) for _ in loops]),
        'cdr.encode_quaternion_stamped': best_rate(count, repeats, lambda: [
            cdr.encode_quaternion_stamped(5, 'world', attitude) for _ in loops]),
        'cdr.encode_pose_stamped': best_rate(count, repeats, lambda: [
            cdr.encode_pose_stamped(5, 'world', (0.0, 0.0, 0.0), attitude) for _ in loops]),
    }


def _read_decode(path: Path) -> None:
    for _, _, _, data in bag.read_messages(path, ['imu']):
        cdr.imu_rates(data)


def _rosbags_read_decode(path: Path) -> None:
    with Reader(path) as reader:
        for _, _, data in reader.messages():
            cdr.imu_rates(data)


def _write_output(path: Path, storage: str, count: int) -> None:
    with bag.BagWriter(path, storage=storage) as writer:
        connection = writer.add_topic('orientation', bag.QUATERNION_STAMPED)
        attitude = (1.0, 0.0, 0.0, 0.0)
        for step in range(count):
            writer.write(connection, step, cdr.encode_quaternion_stamped(step, 'world', attitude))


def _replay_like(source: Path, target: Path, storage: str) -> None:
    attitude, previous = (1.0, 0.0, 0.0, 0.0), None
    with bag.BagWriter(target, storage=storage) as writer:
        connection = writer.add_topic('orientation', bag.QUATERNION_STAMPED)
        for _, bag_time_ns, _, data in bag.read_messages(source, ['imu']):
            stamp, rate = cdr.imu_rates(data)
            if previous is not None:
                attitude = scalar_exp_step(attitude, rate, stamp - previous)
            previous = stamp
            writer.write(connection, bag_time_ns,
                         cdr.encode_quaternion_stamped(bag_time_ns, 'world', attitude))


def bag_rates(count: int, repeats: int, directory: Path) -> dict[str, float]:
    """Bag read/write throughput and the replay-like loop, per storage."""
    stamps = 1e-3 * np.arange(count)
    rates = np.random.default_rng(0).normal(size=(count, 3))
    results = {}
    runs = iter(range(10 ** 6))
    for storage in bag.STORAGES:
        source = directory / f'imu_{storage}'
        bag.write_bag(source, stamps=stamps, rates=rates, storage=storage)
        results[f'read + decode Imu, {storage}'] = best_rate(
            count, repeats, lambda: _read_decode(source))
        results[f'read + decode Imu, {storage}, rosbags iterator'] = best_rate(
            count, repeats, lambda: _rosbags_read_decode(source))
        results[f'encode + write QuaternionStamped, {storage}'] = best_rate(
            count, repeats, lambda: _write_output(directory / f'out{next(runs)}', storage,
                                                  count))
    for source_storage in bag.STORAGES:
        for target_storage in bag.STORAGES:
            source = directory / f'imu_{source_storage}'
            results[f'replay-like {source_storage} -> {target_storage}'] = best_rate(
                count, repeats, lambda: _replay_like(source, directory / f'out{next(runs)}',
                                                     target_storage))
    return results


def main(argv: list[str] | None = None) -> int:
    """Run the measurements and print one line per figure."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--messages', type=int, default=100_000)
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args(argv)
    results = codec_rates(args.messages, args.repeats)
    with tempfile.TemporaryDirectory(prefix='bag_codecs_') as directory:
        results.update(bag_rates(args.messages, args.repeats, Path(directory)))
    width = max(len(name) for name in results)
    for name, value in results.items():
        print(f'{name:{width}s}  {value:12,.0f} msg/s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
