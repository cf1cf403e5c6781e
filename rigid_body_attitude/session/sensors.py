"""The simulated IMU of a dynamics scene, sampled while the session integrates.

:class:`ImuSampler` stands between the clock rules and the propagator
(:attr:`~rigid_body_attitude.session.stream.ClockDriver.advance`): integrating up to a tick, it
stops at every clock time that is a multiple of the sensor period (a whole number of the
scene's steps), takes one sample of :class:`~rigid_body_attitude.core.sensors.ImuModel` from
the attitude and velocity there and at the previous sample instant, and hands it to the sink as
a ``sensor_msgs/msg/Imu`` stamped with the sample time, in the sensor frame, with REP-145
covariances (white-noise variance per sample on the diagonals; orientation not provided). The
first instant after a start, a reset, a ``set_pose`` or a clock gap is a baseline: the samples
resume one period later. The node and the replay tool tick the same session, so a replayed
bag gives the same samples for the same tick times.
"""

from __future__ import annotations

from collections.abc import Callable

from rigid_body_attitude.core.dynamics.effects.translation import Translation
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import GRAVITY_EFFECTS
from rigid_body_attitude.core.sensors.imu import ImuModel, ImuSpec
from rigid_body_attitude.msgs.cdr import simulated_imu_encoder
from rigid_body_attitude.session.times import TimeBase, split_ns

__all__ = ['ImuSampler', 'scene_gravity']

Vector = tuple[float, float, float]
Quat = tuple[float, float, float, float]
_ZERO: Vector = (0.0, 0.0, 0.0)


def scene_gravity(propagator: DynamicsPropagator, spec: ImuSpec) -> Vector:
    """The world gravity [m/s²] the accelerometer feels: a gravity effect's, else the
    section's ``gravity`` (a body held in place), else none."""
    for effect in propagator.effects:
        if effect.name in GRAVITY_EFFECTS:
            x, y, z = (float(value) for value in effect.params['gravity'])
            return x, y, z
    return spec.gravity if spec.gravity is not None else _ZERO


class ImuSampler:
    """Advances a propagator through the sample instants of a simulated IMU."""

    def __init__(self, spec: ImuSpec, propagator: DynamicsPropagator, time_base: TimeBase,
                 emit: Callable[[str, bytes], None]) -> None:
        """Samples of ``spec`` on ``propagator``'s motion; ``emit(topic, data)`` gets each
        serialized Imu (the sink's :meth:`simulated_imu`)."""
        self.spec = spec
        self.propagator = propagator
        self.time_base = time_base
        self.emit = emit
        self.model = ImuModel(spec, scene_gravity(propagator, spec))
        self.encode = simulated_imu_encoder(spec.frame_id, *spec.sample_variances())
        self.translation = next((e for e in propagator.stateful if isinstance(e, Translation)),
                                None)
        #: Samples handed to the sink so far.
        self.count = 0
        self._restart()

    def _restart(self) -> None:
        """The next instant reached is a baseline."""
        self._previous: tuple[Quat, Vector] | None = None
        self._next_ns: int | None = None
        self._time = float('nan')

    def restart(self) -> None:
        """The motion was broken (``set_pose``): the next instant is a new baseline."""
        self._restart()

    def reset(self) -> None:
        """The scene starts again: the sensor too (its constants and noise from the seed)."""
        self.model.reset()
        self._restart()

    def advance_to(self, t_end: float) -> int:
        """:meth:`DynamicsPropagator.advance_to` with a stop and a sample at every sample
        instant on the way; returns the steps taken."""
        propagator, period_ns = self.propagator, self.spec.period_ns
        if propagator.state.time != self._time:  # a (re)start, a reset or a gap
            self._restart()
        if self._next_ns is None:
            start_ns = self.time_base.nanoseconds(propagator.state.time)
            self._next_ns = -(-start_ns // period_ns) * period_ns
        steps = 0
        while True:
            instant_ns = self._next_ns
            t = self.time_base.seconds(instant_ns)
            if t > t_end:
                break
            steps += propagator.advance_to(t)
            self._sample(instant_ns)
            self._next_ns = instant_ns + period_ns
        steps += propagator.advance_to(t_end)
        self._time = propagator.state.time
        return steps

    def _sample(self, instant_ns: int) -> None:
        state = self.propagator.state
        attitude = state.attitude_tuple()
        velocity = self.translation.velocity_floats if self.translation is not None else _ZERO
        previous = self._previous
        self._previous = attitude, velocity
        if previous is None:
            return
        (q0, v0) = previous
        gyro, acc = self.model.sample(q0, attitude, (velocity[0] - v0[0], velocity[1] - v0[1],
                                                     velocity[2] - v0[2]))
        sec, nanosec = split_ns(instant_ns)
        self.count += 1
        self.emit(self.spec.topic, self.encode(sec, nanosec, gyro, acc))
