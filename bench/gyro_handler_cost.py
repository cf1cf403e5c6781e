"""Per-sample cost of the node's gyro input handler with the real-IMU front end, in one run.

Each contender builds a ``strapdown`` session with a null sink and calls the node's own input
handler (:func:`rigid_body_attitude.session.decoding.input_handler`: decode the CDR bytes,
calibrate, rotate into the body frame, subtract the bias, integrate) on ``--samples``
encoded messages (200 Hz, rest noise plus a slow turn), after a levelling phase that is not
timed. The contenders run chunk by chunk in turn (garbage collector off), so a load that
changes during the run hits them alike; minimum and median per sample over the chunks.

* ``imu, no accelerometer``: Imu messages whose acceleration is marked absent: no levelling,
  no sample map (the reference);
* ``imu, levelled``: levelled from gravity, the levelled bias subtracted (inline affine map);
* ``imu, levelled, mount + calibration``: ``mount_rpy`` and a plain scale/misalignment/bias
  file too (the same inline affine map);
* ``imu, levelled, kalibr g-sensitivity``: a kalibr file whose gyro correction takes the
  accelerometer (the general path);
* ``imu, levelled, refine_bias_at_rest``: the rest detector and bias refinement every sample;
* ``angular_velocity``: Vector3Stamped input (no accelerometer).

Usage: ``python bench/gyro_handler_cost.py [--samples 100000] [--chunk 2000]``. Prints a
Markdown table with each cost as a ratio to the reference: the median over the chunks of the
ratio to the reference's chunk of the same round.
"""

from __future__ import annotations

import argparse
import gc
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.msgs import encode_imu, encode_vector3_stamped  # noqa: E402
from rigid_body_attitude.session.decoding import input_handler  # noqa: E402
from rigid_body_attitude.session.parameters import defaults  # noqa: E402
from rigid_body_attitude.session.settings import load_node_scene, open_session  # noqa: E402

BASE_NS = 1_700_000_000 * 10**9
PERIOD_NS = 5_000_000
LEVELLING_SAMPLES = 400  # 2 s of rest at 200 Hz: levelled after 1.25 s


class NullSink:
    """Takes every output and keeps nothing."""

    use_header_stamps = True

    def attitude(self, *args: Any) -> None:
        """Nothing."""

    def sensor_mount(self, *args: Any) -> None:
        """Nothing."""

    def attitude_covariance(self, *args: Any) -> None:
        """Nothing."""

    def dynamics(self, *args: Any) -> None:
        """Nothing."""

    def wants_invariants(self) -> bool:
        """No."""
        return False

    def invariants(self, *args: Any) -> None:
        """Nothing."""

    def diagnostics(self, report: Any) -> None:
        """Nothing."""

    def log(self, level: int, text: str) -> None:
        """Nothing."""


def _messages(count: int, topic: str, accel: bool) -> list[bytes]:
    rng = np.random.default_rng(1)
    gyro = 2e-3 * rng.standard_normal((count, 3)) + [0.003, -0.002, 0.01]
    acc = 0.03 * rng.standard_normal((count, 3)) + [0.0, 0.0, 9.81]
    turn = np.zeros((count, 3))
    turn[LEVELLING_SAMPLES:, 2] = 0.2  # a slow turn after the levelling
    messages = []
    for k in range(count):
        stamp = BASE_NS + k * PERIOD_NS
        rate = tuple((gyro[k] + turn[k]).tolist())
        if topic == 'angular_velocity':
            messages.append(encode_vector3_stamped(stamp, 'imu_link', rate))
        else:
            messages.append(encode_imu(stamp, 'imu_link', rate,
                                       tuple(acc[k].tolist()) if accel else None))
    return messages


def _contenders(folder: Path) -> dict[str, tuple[str, bool, dict[str, Any]]]:
    plain = folder / 'plain.yaml'
    plain.write_text('bias: [0.001, -0.002, 0.0005]\nscale: [1.01, 0.99, 1.0]\n'
                     'misalignment: [[1.0, 0.002, 0.0], [0.0, 1.0, -0.001], [0.0, 0.0, 1.0]]\n')
    kalibr = folder / 'kalibr.yaml'
    kalibr.write_text('imu0:\n  update_rate: 200.0\n  gyroscopes:\n    A: [[1.0e-4, 0, 0], '
                      '[0, 1.0e-4, 0], [0, 0, 1.0e-4]]\n')
    mount = (0.0, 0.0, math.pi / 2)
    return {
        'imu, no accelerometer': ('imu', False, {}),
        'imu, levelled': ('imu', True, {}),
        'imu, levelled, mount + calibration': (
            'imu', True, {'mount_rpy': mount, 'calibration_file': str(plain)}),
        'imu, levelled, kalibr g-sensitivity': (
            'imu', True, {'calibration_file': str(kalibr)}),
        'imu, levelled, refine_bias_at_rest': ('imu', True, {'refine_bias_at_rest': True}),
        'angular_velocity': ('angular_velocity', False, {}),
    }


def _handler(topic: str, accel: bool, parameters: dict[str, Any], samples: int
             ) -> tuple[Any, list[bytes]]:
    """A levelled session's handler and the messages to time."""
    messages = _messages(LEVELLING_SAMPLES + samples, topic, accel)
    values = defaults()
    values.update(parameters)
    session = open_session(load_node_scene('strapdown'), values, NullSink(), time.time_ns,
                           time.monotonic)
    handle = input_handler(session, topic)
    for data in messages[:LEVELLING_SAMPLES]:
        handle(data)
    assert session.alignment_done, session.alignment_text()
    return handle, messages[LEVELLING_SAMPLES:]


def main() -> None:
    """Time every contender, chunk by chunk in turn (a load that drifts hits them alike);
    print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, default=100_000)
    parser.add_argument('--chunk', type=int, default=2000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        runs = {name: _handler(*spec, args.samples)
                for name, spec in _contenders(Path(folder)).items()}
    costs: dict[str, list[float]] = {name: [] for name in runs}
    gc.disable()
    for start in range(0, args.samples, args.chunk):
        for name, (handle, messages) in runs.items():
            chunk = messages[start:start + args.chunk]
            begin = time.perf_counter()
            for data in chunk:
                handle(data)
            costs[name].append((time.perf_counter() - begin) / len(chunk))
    gc.enable()
    reference = costs['imu, no accelerometer']
    print(f'{args.samples} samples in chunks of {args.chunk}, contenders in turn; ratio = '
          f'median over the chunks of the cost / the reference\'s in the same round\n')
    print('| handler | min [µs/sample] | median [µs/sample] | ratio |\n|---|---|---|---|')
    for name, values in costs.items():
        ratio = statistics.median(value / ref for value, ref in zip(values, reference))
        print(f'| {name} | {min(values) * 1e6:.3f} | {statistics.median(values) * 1e6:.3f} | '
              f'{ratio:.3f} |')


if __name__ == '__main__':
    main()
