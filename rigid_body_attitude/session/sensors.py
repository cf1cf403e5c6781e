"""The simulated sensors of a dynamics scene, sampled while the session integrates.

:class:`SensorSampler` stands between the clock rules and the propagator
(:attr:`~rigid_body_attitude.session.stream.ClockDriver.advance`): integrating up to a tick, it
stops at every sample instant of every sensor of the scene's ``sensors`` section (the clock
times that are whole multiples of each sensor's period: the union of the instants), and there
each sensor due takes its sample from the state and hands it to the sink stamped with the
sample time:

* :class:`ImuOutput`: a ``sensor_msgs/msg/Imu`` of
  :class:`~rigid_body_attitude.core.sensors.ImuModel` (mean rate and specific force over the
  interval from the previous instant), in the sensor frame, with REP-145 covariances (white
  noise variance per sample on the diagonals; orientation not provided). The first instant
  after a start, a reset, a ``set_pose`` or a clock gap is a baseline: the samples resume one
  period later.
* :class:`MagnetometerOutput`: a ``sensor_msgs/msg/MagneticField`` of
  :class:`~rigid_body_attitude.core.sensors.MagnetometerModel` [T] in the sensor frame, the
  field of the scene's field model (its ``magnetic_field`` section) at the instant's scene
  time, else the section's local field, with the white noise variance per sample on the
  diagonal of ``magnetic_field_covariance``.
* :class:`StarTrackerOutput`: a ``geometry_msgs/msg/PoseWithCovarianceStamped`` of
  :class:`~rigid_body_attitude.core.sensors.StarTrackerModel`: the measured attitude of the
  body in ``world_frame`` (the header's frame is ``world_frame``, as the node's
  ``pose_with_covariance``: the pose of ``body_frame`` in it), the orientation block its
  covariance about fixed world axes, the position marked unknown
  (:data:`~rigid_body_attitude.session.uncertainty.UNKNOWN_POSITION_VARIANCE`). No message
  while the Sun excludes the instant.

The magnetometer and the star tracker take point samples: they need no baseline, and an
instant is never sampled twice (a ``set_pose`` at an instant already sampled resumes at the
next). Every sensor draws its noise at each of its instants whether the sink wants the sample
or not, and a sample is encoded only when the sink wants it (:meth:`OutputSink.sensor_wanted
<rigid_body_attitude.session.base.OutputSink.sensor_wanted>`: a matched subscription, a topic
of the output bag). So the samples depend only on the scene, the seeds and the instants: not
on how ticks group the instants, on which topics are matched, or on whether the node or the
replay tool ticks the session. The instants are the clock's (multiples of the period in
nanoseconds of the clock), the model reads the scene time of each (seconds since the scene's
first tick: :class:`~rigid_body_attitude.session.times.TimeBase`), and an instant at the
scene's start is sampled at its first tick. A lockstep node repeating its first tick for a
controller that subscribed late sends each sensor's last sample again with it
(:meth:`SensorSampler.resend`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

from rigid_body_attitude.core.dynamics.effects.translation import Translation
from rigid_body_attitude.core.dynamics.scene import GRAVITY_EFFECTS, Scene
from rigid_body_attitude.core.environment.magnetic_field import MagneticFieldModel
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.sensors.imu import ImuModel, ImuSpec
from rigid_body_attitude.core.sensors.magnetometer import MagnetometerModel, MagnetometerSpec
from rigid_body_attitude.core.sensors.star_tracker import StarTrackerModel, StarTrackerSpec
from rigid_body_attitude.msgs.sensor_encoders import (
    attitude_with_covariance_encoder, magnetic_field_encoder, simulated_imu_encoder)
from rigid_body_attitude.session.base import OutputSink
from rigid_body_attitude.session.times import TimeBase, split_ns
from rigid_body_attitude.session.uncertainty import UNKNOWN_POSITION_VARIANCE

__all__ = ['ImuOutput', 'MagnetometerOutput', 'SensorSampler', 'SimulatedSensor',
           'StarTrackerOutput', 'mount_transforms', 'scene_gravity', 'simulated_sensors']

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


class SimulatedSensor(ABC):
    """One sensor of the suite: its topic and period, its sample at an instant."""

    def __init__(self, topic: str, period_ns: int, propagator: DynamicsPropagator,
                 sink: OutputSink) -> None:
        """A sensor publishing on ``topic`` every ``period_ns``, measuring ``propagator``'s
        state, its samples handed to ``sink``."""
        self.topic = topic
        self.period_ns = period_ns
        self.propagator = propagator
        self.sink = sink
        #: Samples taken so far (handed to the sink when it wanted them).
        self.count = 0
        #: The last instant sampled [ns] (``None``: none since the last reset).
        self.last_ns: int | None = None
        #: The last sample given: its instant [ns] and what its message encodes.
        self.last_sample: tuple[int, tuple[object, ...]] | None = None

    def next_instant(self, start_ns: int) -> int:
        """The first instant to sample from ``start_ns`` [ns] on: a multiple of the period,
        after the last instant sampled."""
        instant = -(-start_ns // self.period_ns) * self.period_ns
        if self.last_ns is not None and instant <= self.last_ns:
            return self.last_ns + self.period_ns
        return instant

    def restart(self) -> None:
        """The motion was broken (a ``set_pose``, a clock gap): nothing to forget for a point
        sample."""

    def reset(self) -> None:
        """The scene starts again: the sensor too (its constants and noise from its seed)."""
        self.last_ns = self.last_sample = None
        self.restart()

    def give(self, instant_ns: int, *sample: object) -> None:
        """Hand the sample of ``instant_ns`` to the sink if it wants it (and keep it)."""
        self.count += 1
        self.last_sample = (instant_ns, sample)
        if self.sink.sensor_wanted(self.topic):
            sec, nanosec = split_ns(instant_ns)
            self.sink.simulated_sensor(self.topic, self.encode(sec, nanosec, *sample))

    def resend(self) -> None:
        """The last sample again (a lockstep node repeating its first tick to a controller
        that subscribed late), if the sink wants it."""
        if self.last_sample is not None and self.sink.sensor_wanted(self.topic):
            instant_ns, sample = self.last_sample
            sec, nanosec = split_ns(instant_ns)
            self.sink.simulated_sensor(self.topic, self.encode(sec, nanosec, *sample))

    @abstractmethod
    def encode(self, sec: int, nanosec: int, *sample: Any) -> bytes:
        """The message of one sample stamped ``(sec, nanosec)``."""

    def sample(self, instant_ns: int, t: float) -> None:
        """Take the sample of the instant ``instant_ns`` (scene time ``t`` [s])."""
        self.last_ns = instant_ns
        self._sample(instant_ns, t)

    @abstractmethod
    def _sample(self, instant_ns: int, t: float) -> None:
        """The sensor's own sample: measured, then handed to the sink if it wants it."""

    def set_world_frame(self, world_frame: str) -> None:
        """The frame of world-frame samples (a star tracker's); others ignore it."""


class ImuOutput(SimulatedSensor):
    """The simulated IMU: a mean over the interval from the previous instant (a baseline)."""

    def __init__(self, spec: ImuSpec, propagator: DynamicsPropagator,
                 sink: OutputSink) -> None:
        """Samples of ``spec`` on ``propagator``'s motion."""
        super().__init__(spec.topic, spec.period_ns, propagator, sink)
        self.model = ImuModel(spec, scene_gravity(propagator, spec))
        self._encode = simulated_imu_encoder(spec.frame_id, *spec.sample_variances())
        self.translation = next((e for e in propagator.stateful if isinstance(e, Translation)),
                                None)
        self._previous: tuple[Quat, Vector] | None = None

    def next_instant(self, start_ns: int) -> int:
        """The first multiple of the period from ``start_ns`` on: a baseline, which may be
        an instant already sampled (it publishes nothing)."""
        return -(-start_ns // self.period_ns) * self.period_ns

    def restart(self) -> None:
        """The next instant reached is a baseline."""
        self._previous = None

    def reset(self) -> None:
        """The model again from its seed; the next instant a baseline."""
        self.model.reset()
        super().reset()

    def _sample(self, instant_ns: int, t: float) -> None:
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
        self.give(instant_ns, gyro, acc)

    def encode(self, sec: int, nanosec: int, *sample: Any) -> bytes:
        """A ``sensor_msgs/Imu`` of the rates and specific forces ``sample``."""
        gyro, acc = sample
        return self._encode(sec, nanosec, gyro, acc)


class MagnetometerOutput(SimulatedSensor):
    """The simulated magnetometer: the field at the instant, in the sensor frame."""

    def __init__(self, spec: MagnetometerSpec, propagator: DynamicsPropagator,
                 sink: OutputSink, field: MagneticFieldModel | None = None) -> None:
        """Samples of ``spec`` in ``field`` (``None``: the section's local field)."""
        super().__init__(spec.topic, spec.period_ns, propagator, sink)
        self.model = MagnetometerModel(spec, field)
        self._encode = magnetic_field_encoder(spec.frame_id, spec.magnetic_field_covariance())

    def reset(self) -> None:
        """The model again from its seed (the bias walk at zero)."""
        self.model.reset()
        super().reset()

    def _sample(self, instant_ns: int, t: float) -> None:
        self.give(instant_ns, self.model.sample(t, self.propagator.state.attitude_tuple()))

    def encode(self, sec: int, nanosec: int, *sample: Any) -> bytes:
        """A ``sensor_msgs/MagneticField`` of the measured field ``sample``."""
        (measured,) = sample
        return self._encode(sec, nanosec, measured)


class StarTrackerOutput(SimulatedSensor):
    """The simulated star tracker: the body's attitude in ``world_frame`` with its
    covariance, none while the Sun excludes the instant."""

    def __init__(self, spec: StarTrackerSpec, propagator: DynamicsPropagator,
                 sink: OutputSink) -> None:
        """Samples of ``spec`` (the Sun of the scene's ``sun`` section, if any)."""
        super().__init__(spec.topic, spec.period_ns, propagator, sink)
        self.model = StarTrackerModel(spec, propagator.scene.sun)
        #: Instants the Sun excluded (no message).
        self.excluded = 0
        self.world_frame = ''
        self.set_world_frame('world')

    def set_world_frame(self, world_frame: str) -> None:
        """The header's frame of the following samples."""
        if world_frame != self.world_frame:
            self.world_frame = world_frame
            self._encode = attitude_with_covariance_encoder(world_frame,
                                                            UNKNOWN_POSITION_VARIANCE)

    def reset(self) -> None:
        """The model again from its seed (its misalignment drawn again, the same)."""
        self.model.reset()
        super().reset()

    def _sample(self, instant_ns: int, t: float) -> None:
        measured = self.model.sample(t, self.propagator.state.attitude_tuple())
        if measured is None:
            self.excluded += 1
            return
        self.give(instant_ns, *measured)

    def encode(self, sec: int, nanosec: int, *sample: Any) -> bytes:
        """A ``geometry_msgs/PoseWithCovarianceStamped`` of the measured attitude and its
        covariance ``sample``."""
        attitude, covariance = sample
        return self._encode(sec, nanosec, attitude, covariance)


class SensorSampler:
    """Advances a propagator through the sample instants of the scene's simulated sensors."""

    def __init__(self, sensors: Sequence[SimulatedSensor], propagator: DynamicsPropagator,
                 time_base: TimeBase) -> None:
        """``sensors`` sampled on ``propagator``'s motion at the instants of ``time_base``'s
        clock."""
        self.sensors = tuple(sensors)
        self.propagator = propagator
        self.time_base = time_base
        self._restart()

    def _restart(self) -> None:
        """The instants are found again from the state's time; the IMU's next is a
        baseline."""
        self._next_ns: list[int] | None = None
        self._time = float('nan')
        for sensor in self.sensors:
            sensor.restart()

    def restart(self) -> None:
        """The motion was broken (``set_pose``): the IMU's next instant is a new baseline."""
        self._restart()

    def reset(self) -> None:
        """The scene starts again: every sensor from its seed."""
        for sensor in self.sensors:
            sensor.reset()
        self._restart()

    def set_world_frame(self, world_frame: str) -> None:
        """The frame of the world-frame samples (``world_frame``)."""
        for sensor in self.sensors:
            sensor.set_world_frame(world_frame)

    def resend(self) -> None:
        """Every sensor's last sample again (lockstep's first tick, repeated)."""
        for sensor in self.sensors:
            sensor.resend()

    def advance_to(self, t_end: float) -> int:
        """:meth:`DynamicsPropagator.advance_to` with a stop at every sample instant on the
        way and a sample of each sensor due there; returns the steps taken."""
        propagator, sensors = self.propagator, self.sensors
        if propagator.state.time != self._time:  # a (re)start, a reset or a gap
            self._restart()
        next_ns = self._next_ns
        if next_ns is None:
            start_ns = self.time_base.nanoseconds(propagator.state.time)
            next_ns = self._next_ns = [sensor.next_instant(start_ns) for sensor in sensors]
        steps = 0
        while True:
            instant_ns = min(next_ns)
            t = self.time_base.seconds(instant_ns)
            if t > t_end:
                break
            steps += propagator.advance_to(t)
            for index, sensor in enumerate(sensors):
                if next_ns[index] == instant_ns:
                    sensor.sample(instant_ns, t)
                    next_ns[index] = instant_ns + sensor.period_ns
        steps += propagator.advance_to(t_end)
        self._time = propagator.state.time
        return steps


def simulated_sensors(scene: Scene, propagator: DynamicsPropagator, sink: OutputSink,
                      field: MagneticFieldModel | None = None) -> list[SimulatedSensor]:
    """The sensors of ``scene``'s ``sensors`` section in section order, their samples handed
    to ``sink``; the magnetometer in ``field`` (the scene's field model), else in its
    section's local field."""
    sensors: list[SimulatedSensor] = []
    suite = scene.sensors
    if suite.imu is not None:
        sensors.append(ImuOutput(suite.imu, propagator, sink))
    if suite.magnetometer is not None:
        sensors.append(MagnetometerOutput(suite.magnetometer, propagator, sink, field))
    if suite.star_tracker is not None:
        sensors.append(StarTrackerOutput(suite.star_tracker, propagator, sink))
    return sensors


def mount_transforms(scene: Scene, body_frame: str) -> list[tuple[str, str, Quat]]:
    """The static transforms of the sensors' mounts: ``(body_frame, frame_id, rotation (w,
    x, y, z))`` for each frame of the ``sensors`` section other than ``body_frame``, once
    per frame (a frame has one mount), in section order."""
    transforms: dict[str, Quat] = {}
    for _, spec in scene.sensors.items():
        if spec.frame_id != body_frame:
            transforms.setdefault(spec.frame_id, spec.mount())
    return [(body_frame, frame, mount) for frame, mount in transforms.items()]
