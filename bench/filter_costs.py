"""What the attitude filter costs per gyro sample in the session, without ROS.

Feeds the node's session (``open_session``, as the node and the replay build it) a body at
rest at 1 kHz (gyro 0.01, -0.02, 0.03 rad/s, the accelerometer's gravity, a magnetometer
sample every ``--mag-every`` gyro samples) and measures the process time per sample of the
``strapdown`` scene and of the ``imu_filter`` scene (levelled, then every update: gravity,
zero rate, magnetometer), and within the latter the time spent in the filter's updates and in
the covariance of ``accel/filtered``. A sink that keeps nothing: the session's own work.

    python bench/filter_costs.py --samples 20000 --repeats 3
"""

import argparse
import sys
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from rigid_body_attitude.core.estimation.estimator import AttitudeEstimator  # noqa: E402
from rigid_body_attitude.session import estimation  # noqa: E402
from rigid_body_attitude.session.parameters import defaults  # noqa: E402
from rigid_body_attitude.session.settings import load_node_scene, open_session  # noqa: E402

BASE_NS = 1_700_000_000 * 10**9
GYRO, ACCEL, FIELD = (0.01, -0.02, 0.03), (0.3, -0.4, 9.79), (0.0, 2e-5, -4e-5)


class NullSink:
    """An output sink that keeps nothing."""

    use_header_stamps = True

    def __getattr__(self, name: str) -> Any:
        return lambda *args: None


class Timed:
    """Process time spent in a wrapped function, and its calls."""

    def __init__(self, owner: Any, name: str) -> None:
        self.seconds, self.calls = 0.0, 0
        original = getattr(owner, name)

        def timed(*args: Any) -> Any:
            began = time.process_time()
            try:
                return original(*args)
            finally:
                self.seconds += time.process_time() - began
                self.calls += 1
        setattr(owner, name, timed)


def run(scene: str, samples: int, mag_every: int) -> float:
    """Process time per sample [µs] of ``samples`` at 1 kHz through ``scene``'s session."""
    values = {**defaults(), 'scene': scene}
    session: Any = open_session(load_node_scene(scene), values, NullSink(), lambda: 0,
                                lambda: 0.0)
    filtered = scene == 'imu_filter'
    began = time.process_time()
    for k in range(samples):
        sec, nanosec = divmod(BASE_NS + k * 1_000_000, 10**9)
        if filtered and k % mag_every == 0:
            session.magnetic_field(sec, nanosec, 'base_link', FIELD)
        session.gyro(sec, nanosec, GYRO, None, ACCEL)
    return (time.process_time() - began) / samples * 1e6


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, default=20000)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--mag-every', type=int, default=10)
    args = parser.parse_args()
    update = Timed(AttitudeEstimator, 'update')
    covariance = Timed(estimation.Estimation, '_covariance_at')
    strapdown = min(run('strapdown', args.samples, args.mag_every) for _ in range(args.repeats))
    update.seconds = covariance.seconds = 0.0
    update.calls = 0
    filtered = [run('imu_filter', args.samples, args.mag_every) for _ in range(args.repeats)]
    per_sample = 1e6 / (args.samples * args.repeats)
    print('| what | µs per sample (1 kHz) |')
    print('|---|---|')
    print(f'| strapdown scene (session) | {strapdown:.1f} |')
    print(f'| imu_filter scene (session), fastest of {args.repeats} | {min(filtered):.1f} |')
    print(f'| of which the filter\'s updates ({update.calls} in all, '
          f'{update.seconds / update.calls * 1e3:.2f} ms each) | '
          f'{update.seconds * per_sample:.1f} |')
    print(f'| of which the accel/filtered covariance | {covariance.seconds * per_sample:.1f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
