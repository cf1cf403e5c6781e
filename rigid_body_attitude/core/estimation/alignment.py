"""Levelling from gravity: the initial roll and pitch from the accelerometer at rest.

At rest an accelerometer measures the specific force ``f = −g``, i.e. ``+|g|`` along the world
*up* direction, seen in the sensor (body) frame: ``f_body = R(q)ᵀ up_world |g|`` with ``q``
the body → world attitude (:mod:`rigid_body_attitude.core.attitude.quaternion`). The world axes:

* ``enu`` (REP-103, the default): x east, y north, z up — ``up = (0, 0, 1)``;
* ``nwu``: x north, y west, z up — ``up = (0, 0, 1)``;
* ``ned``: x north, y east, z down — ``up = (0, 0, −1)``.

:func:`levelled_attitude` returns ``q = Rz(yaw) Ry(pitch) Rx(roll)`` (intrinsic z-y'-x'',
REP-103's roll, pitch, yaw) with roll and pitch from ``f_body`` and the yaw given (gravity
says nothing about heading): with ``s = +1`` for a z-up world and ``−1`` for a z-down one,
``roll = atan2(s f_y, s f_z)`` and ``pitch = atan2(−s f_x, √(f_y² + f_z²))``.

:class:`GravityAligner` is the state machine a session feeds sample by sample: it waits until
its :class:`~rigid_body_attitude.core.estimation.rest.RestDetector` reports rest, averages
``align_seconds`` of rest samples (the rest must hold throughout, else it waits again), then
gives the levelled attitude and the window's mean rate as the initial gyro bias estimate. A
body that never rests (a node restarted in flight) is aligned after ``align_timeout`` seconds
from the quietest detector window seen (tilt from its mean specific force; no bias estimate)
and :attr:`GravityAligner.status` says so.
"""

from __future__ import annotations

import math

from rigid_body_attitude.core.attitude.quaternion import from_rpy
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.estimation.rest import RestDetector

__all__ = ['ALIGNED', 'ALIGNED_WITHOUT_REST', 'ALIGNING', 'GravityAligner', 'WAITING',
           'WORLD_AXES', 'levelled_attitude', 'tilt_angle', 'world_up']

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]

#: World axes conventions and their up direction.
WORLD_AXES: dict[str, Vec] = {'enu': (0.0, 0.0, 1.0), 'nwu': (0.0, 0.0, 1.0),
                              'ned': (0.0, 0.0, -1.0)}
#: States of :class:`GravityAligner`.
WAITING = 'waiting'
ALIGNING = 'aligning'
ALIGNED = 'aligned'
ALIGNED_WITHOUT_REST = 'aligned_without_rest'


def world_up(world_axes: str) -> Vec:
    """The world's up direction for ``'enu'``, ``'nwu'`` or ``'ned'`` (unit vector)."""
    if world_axes not in WORLD_AXES:
        raise InputError(f'Expected world_axes to be one of {", ".join(sorted(WORLD_AXES))}, '
                         f'got {world_axes!r}')
    return WORLD_AXES[world_axes]


def levelled_attitude(specific_force_body: Vec, yaw: float = 0.0,
                      world_axes: str = 'enu') -> Quat:
    """The body → world attitude ``(w, x, y, z)`` whose up agrees with the measured specific
    force [m/s², body frame] at rest, with heading ``yaw`` [rad] about the world z axis."""
    fx, fy, fz = specific_force_body
    if not all(math.isfinite(value) for value in (fx, fy, fz, yaw)) or (
            fx == 0.0 and fy == 0.0 and fz == 0.0):
        raise InputError(f'Expected a finite non-zero specific force and a finite yaw, got '
                         f'{specific_force_body!r} and {yaw!r}')
    s = world_up(world_axes)[2]
    roll = math.atan2(s * fy, s * fz)
    pitch = math.atan2(-s * fx, math.hypot(fy, fz))
    w, x, y, z = from_rpy([roll, pitch, yaw]).tolist()
    return w, x, y, z


def _up_in_body(q: Quat, up: Vec) -> Vec:
    """``R(q)ᵀ up`` for a unit quaternion ``q``."""
    w, x, y, z = q
    ux, uy, uz = up
    # Third column etc. of R written out: Rᵀ u = (R[0]·u..., ) with R rows expanded.
    r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return (r00 * ux + r10 * uy + r20 * uz, r01 * ux + r11 * uy + r21 * uz,
            r02 * ux + r12 * uy + r22 * uz)


def tilt_angle(q_a: Quat, q_b: Quat, world_axes: str = 'enu') -> float:
    """Angle [rad] between the world up directions seen in the body frame by two attitudes
    (the tilt difference; heading is ignored)."""
    up = world_up(world_axes)
    a, b = _up_in_body(q_a, up), _up_in_body(q_b, up)
    dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    cross = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    return math.atan2(math.sqrt(cross[0] ** 2 + cross[1] ** 2 + cross[2] ** 2), dot)


class GravityAligner:
    """Wait for rest, average ``align_seconds`` of it, level; or level anyway after a timeout.

    Args:
        align_seconds: length of the averaged rest window [s].
        align_timeout: time after the first sample at which a body that has not rested long
            enough is aligned from the quietest window seen [s].
        initial_yaw: heading of the aligned attitude [rad] about the world z axis.
        world_axes: ``'enu'``, ``'nwu'`` or ``'ned'``.
        detector: the rest detector (a default :class:`RestDetector` if ``None``).

    Feed :meth:`update` every sample; once :attr:`done`, :attr:`attitude` is the levelled
    body → world quaternion ``(w, x, y, z)``, :attr:`gyro_bias` the bias estimate [rad/s]
    and :attr:`status` the state in words.
    """

    def __init__(self, align_seconds: float = 1.0, align_timeout: float = 10.0,
                 initial_yaw: float = 0.0, world_axes: str = 'enu',
                 detector: RestDetector | None = None) -> None:
        for name, value in (('align_seconds', align_seconds), ('align_timeout', align_timeout)):
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(f'Expected {name} to be a positive number of seconds, got '
                                 f'{value!r}')
        if not math.isfinite(initial_yaw):
            raise InputError(f'Expected initial_yaw to be finite [rad], got {initial_yaw!r}')
        world_up(world_axes)
        self.align_seconds = float(align_seconds)
        self.align_timeout = float(align_timeout)
        self.initial_yaw = float(initial_yaw)
        self.world_axes = world_axes
        self.detector = detector if detector is not None else RestDetector()
        self.reset()

    def reset(self) -> None:
        """Start again: wait for rest (the detector's measured noise floors are kept)."""
        self.state = WAITING
        self.elapsed = 0.0
        self._sums = [0.0] * 6
        self._seconds = 0.0
        self._quietest = math.inf
        self._quietest_accel: Vec = (0.0, 0.0, 0.0)
        self.attitude: Quat = (1.0, 0.0, 0.0, 0.0)
        self.gyro_bias: Vec = (0.0, 0.0, 0.0)
        self.specific_force: Vec = (0.0, 0.0, 0.0)

    @property
    def done(self) -> bool:
        """Whether the attitude and the bias estimate are set."""
        return self.state in (ALIGNED, ALIGNED_WITHOUT_REST)

    def update(self, wx: float, wy: float, wz: float, ax: float, ay: float, az: float,
               dt: float) -> bool:
        """Add one sample (rates [rad/s], specific force [m/s²], sensor/body frame; its
        interval [s]); returns :attr:`done`."""
        if self.done:
            return True
        self.elapsed += dt
        detector = self.detector
        if detector.update(wx, wy, wz, ax, ay, az, dt):
            sums = self._sums
            sums[0] += wx * dt
            sums[1] += wy * dt
            sums[2] += wz * dt
            sums[3] += ax * dt
            sums[4] += ay * dt
            sums[5] += az * dt
            self._seconds += dt
            self.state = ALIGNING
            if self._seconds >= self.align_seconds:
                self._finish_at_rest()
                return True
        else:
            if self.state == ALIGNING:
                self._sums = [0.0] * 6
                self._seconds = 0.0
            self.state = WAITING
        if detector.window_full and detector.gyro_spread < self._quietest:
            self._quietest = detector.gyro_spread
            self._quietest_accel = detector.mean_accel
        if self.elapsed >= self.align_timeout and self.state == WAITING:
            self._finish_without_rest()
            return True
        return False

    def _finish_at_rest(self) -> None:
        s = [value / self._seconds for value in self._sums]
        self.gyro_bias = (s[0], s[1], s[2])
        self.specific_force = (s[3], s[4], s[5])
        self.attitude = levelled_attitude(self.specific_force, self.initial_yaw, self.world_axes)
        self.detector.set_gyro_bias(self.gyro_bias)
        self.state = ALIGNED

    def _finish_without_rest(self) -> None:
        # The quietest full window's specific force; level if there was no full window or no
        # specific force at all (zeros).
        accel = self._quietest_accel
        if accel == (0.0, 0.0, 0.0):
            accel = world_up(self.world_axes)
        self.specific_force = accel
        self.attitude = levelled_attitude(accel, self.initial_yaw, self.world_axes)
        self.gyro_bias = (0.0, 0.0, 0.0)
        self.state = ALIGNED_WITHOUT_REST

    @property
    def status(self) -> str:
        """The state in words, e.g. ``waiting for rest: gyro spread 0.05 rad/s above
        threshold 0.01``, ``aligning 0.4/1.0 s``, ``aligned``."""
        if self.state == ALIGNED:
            return (f'aligned at rest over {self.align_seconds:g} s: roll/pitch from gravity, '
                    f'yaw {self.initial_yaw:g} rad')
        if self.state == ALIGNED_WITHOUT_REST:
            return (f'aligned without rest after timeout ({self.align_timeout:g} s): tilt from '
                    f'the quietest window, gyro bias not estimated')
        if self.state == ALIGNING:
            return f'aligning {self._seconds:.1f}/{self.align_seconds:g} s'
        return (f'waiting for rest ({self.elapsed:.1f}/{self.align_timeout:g} s): '
                f'{self.detector.reason()}')
