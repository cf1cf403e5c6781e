"""Throughput of the rosbag2 layer: CDR codecs, bag reading and writing, a replay-like loop.

Prints messages per second (best of ``--repeats`` runs) for

* ``rosbags`` ``deserialize_cdr`` / ``serialize_cdr`` of ``sensor_msgs/msg/Imu`` (reference),
* the hand-written codecs of :mod:`rigid_body_attitude.msgs.cdr` and the checked decoders of
  :mod:`rigid_body_attitude.msgs.decoders` on each of their paths: one frame id (the primed
  one-call path), two frame ids alternating (the look-up path), big-endian messages (the full
  check), and a malformed message (the full check raising ``MalformedMessage``),
* reading a bag of Imu messages and decoding the rates (sqlite3, mcap fast path, mcap through
  ``rosbags``' iterator), writing ``QuaternionStamped`` output with :class:`BagWriter`,
* a replay-like loop: read Imu, decode, one ``scalar_exp_step``, encode and write a
  ``QuaternionStamped`` (an upper bound for ``replay``; it has no stream checks).

Usage: ``python bench/bag_codecs.py [--messages 100000] [--repeats 3] [--codecs-only]``.
Bags go to a temporary directory that is removed afterwards. The numbers depend on the machine
and its load.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import deque
from collections.abc import Callable, Sequence
from itertools import islice, repeat
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader

from rigid_body_attitude import bag, msgs
from rigid_body_attitude.msgs import cdr, decoders
from rigid_body_attitude.msgs.errors import MalformedMessage
from rigid_body_attitude.core.quaternion import scalar_exp_step


def best_rate(count: int, repeats: int, run: Callable[[], object]) -> float:
    """Largest ``count / seconds`` over ``repeats`` runs of ``run``."""
    best = float('inf')
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return count / best


def _each(decode: Callable[[bytes], object], messages: Sequence[bytes], count: int
          ) -> Callable[[], object]:
    """A run decoding ``count`` messages cycled from ``messages`` (results dropped)."""
    cycled = list(islice(messages * (count // len(messages) + 1), count))
    return lambda: deque(map(decode, cycled), 0)


def _refusing(decode: Callable[[bytes], object], data: bytes, count: int
              ) -> Callable[[], object]:
    def run() -> None:
        for message in repeat(data, count):
            try:
                decode(message)
            except MalformedMessage:
                pass
    return run


def decoder_rates(count: int, repeats: int) -> dict[str, float]:
    """Per-message cost of the checked decoders on each path."""
    stamp = 1_700_000_000_000_000_000
    imu = cdr.encode_imu(stamp, 'base_link', (0.1, 0.2, 0.3))
    other_imu = cdr.encode_imu(stamp, 'imu_link', (0.1, 0.2, 0.3))
    big_endian_imu = bytes(bag.typestore().serialize_cdr(
        bag.typestore().deserialize_cdr(imu, msgs.IMU), msgs.IMU, little_endian=False))
    vector = cdr.encode_vector3_stamped(stamp, 'base_link', (0.1, 0.2, 0.3))
    wrench = cdr.encode_wrench_stamped(stamp, 'base_link', (1.0, 2.0, 3.0), (0.1, 0.2, 0.3))
    pose = cdr.encode_pose_stamped(stamp, 'world', (1.0, 2.0, 3.0), (1.0, 0.0, 0.0, 0.0))
    cases = {
        'decode_imu_rate, one frame id': (decoders.decode_imu_rate, [imu]),
        'decode_imu_rate, two frame ids alternating': (decoders.decode_imu_rate,
                                                       [imu, other_imu]),
        'decode_imu_rate, big-endian (full check)': (decoders.decode_imu_rate, [big_endian_imu]),
        'decode_vector3_stamped, one frame id': (decoders.decode_vector3_stamped, [vector]),
        'decode_wrench_stamped, one frame id': (decoders.decode_wrench_stamped, [wrench]),
        'decode_pose_stamped, one frame id': (decoders.decode_pose_stamped, [pose]),
        'cdr.imu_rates (float stamp)': (cdr.imu_rates, [imu]),
    }
    results = {name: best_rate(count, repeats, _each(decode, messages, count))
               for name, (decode, messages) in cases.items()}
    results['decode_imu_rate, truncated (MalformedMessage)'] = best_rate(
        count, repeats, _refusing(decoders.decode_imu_rate, imu[:100], count))
    return results


def codec_rates(count: int, repeats: int) -> dict[str, float]:
    """Per-message codec throughput (no bag I/O)."""
    store = bag.typestore()
    data = cdr.encode_imu(1_700_000_000_000_000_000, 'base_link', (0.1, 0.2, 0.3))
    message = store.deserialize_cdr(data, msgs.IMU)
    rate, attitude = (0.1, 0.2, 0.3), (1.0, 0.0, 0.0, 0.0)
    loops = range(count)
    return {
        'rosbags deserialize_cdr Imu': best_rate(count, repeats, lambda: [
            store.deserialize_cdr(data, msgs.IMU) for _ in loops]),
        'rosbags serialize_cdr Imu': best_rate(count, repeats, lambda: [
            store.serialize_cdr(message, msgs.IMU) for _ in loops]),
        **decoder_rates(count, repeats),
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
        connection = writer.add_topic('orientation', msgs.QUATERNION_STAMPED)
        attitude = (1.0, 0.0, 0.0, 0.0)
        for step in range(count):
            writer.write(connection, step, cdr.encode_quaternion_stamped(step, 'world', attitude))


def _replay_like(source: Path, target: Path, storage: str) -> None:
    attitude, previous = (1.0, 0.0, 0.0, 0.0), None
    with bag.BagWriter(target, storage=storage) as writer:
        connection = writer.add_topic('orientation', msgs.QUATERNION_STAMPED)
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
    parser.add_argument('--codecs-only', action='store_true',
                        help='measure the codecs only (no bag reading or writing)')
    args = parser.parse_args(argv)
    results = codec_rates(args.messages, args.repeats)
    if not args.codecs_only:
        with tempfile.TemporaryDirectory(prefix='bag_codecs_') as directory:
            results.update(bag_rates(args.messages, args.repeats, Path(directory)))
    width = max(len(name) for name in results)
    for name, value in results.items():
        print(f'{name:{width}s}  {value:12,.0f} msg/s  {1e6 / value:7.3f} µs/msg')
    return 0


if __name__ == '__main__':
    sys.exit(main())
