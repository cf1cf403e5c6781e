"""The simulated sensors priced, in one run.

* **Per sample** [µs]: :meth:`ImuModel.sample` (mean rate from the attitude increment, the
  specific force, every error term, saturation and quantisation on) and the Imu encoding
  (:mod:`~rigid_body_attitude.msgs.sensor_encoders`); :meth:`MagnetometerModel.sample` (the
  local field, hard and soft iron, noise, bias walk, saturation and quantisation on) and its
  MagneticField encoding; :meth:`StarTrackerModel.sample` (misalignment, noise, the covariance
  about world axes and the Sun exclusion test on) and its PoseWithCovarianceStamped encoding;
  ``timeit`` on CPU time, best of ``--repeats``; beside them one plain-float strapdown step,
  the run's yardstick (a busy machine slows every figure: compare the ratio).
* **Per simulated second** [ms]: a dynamics session (rk4, 1 ms step, a tumbling box, ticks of
  20 ms) without sensors, with a 200 Hz and a 1 kHz IMU, and with a 200 Hz IMU, a 100 Hz
  magnetometer and a 10 Hz star tracker, every sample encoded (as for a matched subscription)
  and handed to a sink that drops it; the ratio to the session without sensors. The sessions
  run in turn ``--repeats`` times and each keeps its best, so a busy machine slows all alike.

Usage: ``python bench/sensor_costs.py [--seconds 10] [--repeats 5]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time
import timeit
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.attitude import quaternion  # noqa: E402
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping  # noqa: E402
from rigid_body_attitude.core.environment.sun import ConstantSunDirection  # noqa: E402
from rigid_body_attitude.core.sensors import (  # noqa: E402
    ImuModel, ImuSpec, MagnetometerModel, MagnetometerSpec, StarTrackerModel, StarTrackerSpec)
from rigid_body_attitude.msgs.sensor_encoders import (  # noqa: E402
    attitude_with_covariance_encoder, magnetic_field_encoder, simulated_imu_encoder)
from rigid_body_attitude.session.dynamics import DynamicsSession  # noqa: E402
from rigid_body_attitude.session.parameters import defaults  # noqa: E402

START_NS = 1_700_000_000 * 10**9
TICK_NS = 20_000_000


class DroppingSink:
    """An output sink that wants every simulated sample and keeps nothing."""

    use_header_stamps = True

    def sensor_wanted(self, topic: str) -> bool:
        """Every sample is encoded, as for a matched subscription."""
        return True

    def __getattr__(self, name: str) -> Any:
        return lambda *args: None


def per_sample(repeats: int) -> tuple[float, float, float]:
    """µs per :meth:`ImuModel.sample`, per encoded Imu and per plain-float strapdown step
    (``scalar_exp_step``: the yardstick of this run, priced alone in docs/performance.md)."""
    spec = ImuSpec(rate=200.0, seed=1, mount_rpy=(0.1, 0.2, 0.3), gyroscope_range=35.0,
                   gyroscope_resolution=1e-4, accelerometer_range=160.0,
                   accelerometer_resolution=1e-3, accelerometer_random_walk=1e-3)
    model = ImuModel(spec, (0.0, 0.0, -9.80665))
    q0 = (1.0, 0.0, 0.0, 0.0)
    q1 = tuple(quaternion.exp([0.004, -0.002, 0.003]).tolist())
    count = 20_000
    sample = min(timeit.repeat(lambda: model.sample(q0, q1, (0.0, 0.0, 0.01)),
                               number=count, repeat=repeats, timer=time.process_time)
                 ) / count * 1e6
    encode = simulated_imu_encoder('imu_link', *spec.sample_variances())
    gyro, acc = model.sample(q0, q1)
    encoded = min(timeit.repeat(lambda: encode(1, 2, gyro, acc), number=count,
                                repeat=repeats, timer=time.process_time)) / count * 1e6
    omega = (0.3, 2.0, 0.1)
    step = min(timeit.repeat(lambda: quaternion.scalar_exp_step(q1, omega, 0.005), number=count,
                             repeat=repeats, timer=time.process_time)) / count * 1e6
    return sample, encoded, step


def attitude_sensor_samples(repeats: int) -> tuple[float, float, float, float]:
    """µs per :meth:`MagnetometerModel.sample`, per :meth:`StarTrackerModel.sample` (every
    term on, a sample the Sun does not exclude) and per encoding of each."""
    magnetometer = MagnetometerModel(MagnetometerSpec(
        rate=100.0, noise_density=1e-8, intensity=5e-5, inclination=1.2, declination=0.07,
        mount_rpy=(0.1, 0.2, 0.3), seed=1, random_walk=1e-10, hard_iron=(2e-5, -1e-5, 7e-6),
        soft_iron=((1.08, 0.05, -0.02), (0.05, 0.93, 0.04), (-0.02, 0.04, 1.01)),
        range=8e-4, resolution=1.5e-7))
    star_tracker = StarTrackerModel(StarTrackerSpec(
        rate=10.0, mount_rpy=(0.1, 0.2, 0.3), seed=1, misalignment_stddev=1e-4,
        sun_exclusion_angle=0.5), ConstantSunDirection((0.0, -1.0, 0.0)))
    q = tuple(quaternion.exp([0.4, -0.2, 0.3]).tolist())
    count = 20_000
    costs = []
    for model in (magnetometer, star_tracker):
        assert model.sample(1.0, q) is not None
        costs.append(min(timeit.repeat(lambda: model.sample(1.0, q), number=count,
                                       repeat=repeats, timer=time.process_time)) / count * 1e6)
    field = magnetometer.sample(1.0, q)
    encode_field = magnetic_field_encoder('magnetometer_link',
                                          magnetometer.spec.magnetic_field_covariance())
    measured = star_tracker.sample(1.0, q)
    assert measured is not None
    encode_attitude = attitude_with_covariance_encoder('world', 1e9)
    for encode in (lambda: encode_field(1, 2, field),
                   lambda: encode_attitude(1, 2, measured[0], measured[1])):
        costs.append(min(timeit.repeat(encode, number=count, repeat=repeats,
                                       timer=time.process_time)) / count * 1e6)
    return costs[0], costs[1], costs[2], costs[3]


#: The sessions priced: their names and ``sensors`` sections.
SUITES: dict[str, dict[str, Any]] = {
    'no sensors': {},
    'an IMU at 200 Hz': {'imu': {'rate': 200.0, 'seed': 1}},
    'an IMU at 1000 Hz': {'imu': {'rate': 1000.0, 'seed': 1}},
    'an IMU at 200 Hz, a magnetometer at 100 Hz and a star tracker at 10 Hz': {
        'imu': {'rate': 200.0, 'seed': 1},
        'magnetometer': {'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5,
                         'inclination': 1.2, 'seed': 1},
        'star_tracker': {'rate': 10.0, 'boresight': [0.0, 1.0, 0.0], 'seed': 1}},
}


def session_cost(sensors: dict[str, Any], seconds: float) -> float:
    """CPU milliseconds per simulated second of a dynamics session with ``sensors``."""
    data: dict[str, Any] = {
        'rate_source': 'dynamics', 'step': 0.001, 'integrator': 'rk4',
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': [0.3, 2.0, 0.1]}}
    if sensors:
        data['sensors'] = sensors
    session = DynamicsSession(scene_from_mapping(data), defaults(), DroppingSink(),
                              lambda: START_NS, time.monotonic)
    ticks = int(seconds * 1e9 / TICK_NS)
    started = time.process_time()
    for k in range(ticks + 1):
        session.tick(START_NS + k * TICK_NS)
    return (time.process_time() - started) / seconds * 1e3


def main() -> None:
    """Print the two tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args()
    sample, encoded, step = per_sample(args.repeats)
    print(f'ImuModel.sample: {sample:.2f} us per sample; Imu encoding: {encoded:.2f} us; '
          f'one strapdown step (scalar_exp_step): {step:.2f} us, the sample {sample / step:.1f}x')
    magnetometer, star_tracker, field, attitude = attitude_sensor_samples(args.repeats)
    print(f'MagnetometerModel.sample: {magnetometer:.2f} us per sample, '
          f'{magnetometer / step:.1f}x the strapdown step; MagneticField encoding: '
          f'{field:.2f} us; StarTrackerModel.sample: {star_tracker:.2f} us, '
          f'{star_tracker / step:.1f}x; PoseWithCovarianceStamped encoding: {attitude:.2f} us')
    costs = [min(run) for run in zip(*([session_cost(sensors, args.seconds)
                                        for sensors in SUITES.values()]
                                       for _ in range(args.repeats)))]
    bare = costs[0]
    print(f'dynamics session, no sensors: {bare:.1f} ms CPU per simulated second')
    for (name, sensors), cost in list(zip(SUITES.items(), costs))[1:]:
        samples = sum(section['rate'] for section in sensors.values())
        print(f'with {name}: {cost:.1f} ms per simulated second, {cost / bare:.3f}x; '
              f'{(cost - bare) * 1e3 / samples:.1f} us per sample in the session')


if __name__ == '__main__':
    main()
