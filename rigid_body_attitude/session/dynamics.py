"""The dynamics session: Euler's equations advanced to each tick of a clock, with commands.

At each tick (:meth:`DynamicsSession.tick`, the node's timer on its clock, ``use_sim_time``
works) the state is integrated up to the clock's time under the clock rules
(:class:`~rigid_body_attitude.session.stream.ClockDriver`) and every output goes to the sink,
stamped with the propagated time. **Scene time** (what the effects and sensors read: the orbit,
the field, a controller's sample instants) is 0 at the scene's first tick, and again at the
first tick after a reset or a backward clock jump (:class:`~.times.TimeBase`), whatever the
clock's origin: the batch engine's time from 0, in the node and the replay alike. Commands
(``wrench``: torque and force; ``rotor_torque``; ``dipole``; the wheels') are held from their
stamp on (:class:`~rigid_body_attitude.session.stream.CommandStream`); one received before
the first tick, stamped before the start or far from the clock is refused
(:meth:`~.stream.CommandStream.timing`), so no command moves the scene's time.
The session times its own work (the monotonic clock) to report a scene that cannot keep up:
its real-time factor and its lag behind the clock. A scene with simulated sensors (its
``sensors`` section) is integrated through a
:class:`~rigid_body_attitude.session.sensors.SensorSampler`, which samples them on the way. On the
node's own sim clock (:mod:`~rigid_body_attitude.session.sim_clock`: ``publish_clock``,
``lockstep``) the ticks are its sim times and, in lockstep, a command counts only when stamped
with the current tick.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.core.propagator import DynamicsPropagator, MAX_STEPS_PER_CALL
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.session.actuators import (
    MagnetorquerReport, WHEEL_COMMAND_TOPIC, WHEEL_REASONS, WheelArray)
from rigid_body_attitude.session.base import OutputSink, Session
from rigid_body_attitude.session.outputs import OutputSample
from rigid_body_attitude.session.parameters import check_values
from rigid_body_attitude.session.reports import LEVEL_WARN, PeriodCounts, body_frame_velocity
from rigid_body_attitude.session.sensors import SensorSampler, simulated_sensors
from rigid_body_attitude.session.sim_clock import SimClock
from rigid_body_attitude.session.stream import ClockDriver, CommandStream, Outcome
from rigid_body_attitude.session.times import (
    seconds_to_ns, split_ns, stamp_problem, TimeBase, to_ns)

__all__ = ['DynamicsSession']

_DETAIL = {
    'non_finite': 'a non-finite value (NaN or Inf); message ignored',
    'out_of_range': 'a value beyond 1e12 (N, N m); message ignored',
    'stale_stamp': 'a stamp older than the last command, than the scene\'s start or than the '
                   'clock by more than time_jump_threshold (in lockstep: than the current '
                   'tick, or a second command for it); message ignored (parameter '
                   '`use_header_stamps`)',
    'future_stamp': 'a stamp after the current lockstep tick, or more than time_jump_threshold '
                    'ahead of the clock; a command must carry the stamp of the tick it answers '
                    '(lockstep) or of the clock; message ignored (parameters `lockstep`, '
                    '`time_jump_threshold`)',
    'not_started': 'received before the scene\'s first tick (the first after a start, a reset '
                   'or a backward clock jump: scene time 0); message ignored',
}


class DynamicsSession(Session):
    """Euler's equations of a dynamics scene, advanced to each clock tick."""

    propagator: DynamicsPropagator

    def __init__(self, scene: Scene, values: Mapping[str, Any], sink: OutputSink,
                 clock_ns: Callable[[], int], monotonic: Callable[[], float]) -> None:
        """The scene's dynamics propagator, clock rules and command stream."""
        self.propagator = DynamicsPropagator(scene)
        #: Scene time: 0 at the tick that (re)started the scene.
        self.time_base = TimeBase()
        self._tick_ns = 0
        self.clock = ClockDriver(self.propagator, values['time_jump_threshold'],
                                 self._scene_start)
        self.commands = CommandStream(self.propagator)
        inputs = self.propagator.input_names
        #: The WrenchStamped fields the scene takes (``torque``, ``force``).
        self.wrench_inputs = tuple(name for name in ('torque', 'force') if name in inputs)
        #: The reaction-wheel array (``wheels/command``, ``wheels/state``), or None.
        self.wheels = WheelArray.of(self.propagator)
        self.rods = MagnetorquerReport.of(self.propagator)
        #: The commands a lockstep tick waits for (the inputs; one topic for the wheels).
        self.command_inputs = self.wrench_inputs + tuple(
            key for key, name in (('rotor_torque', 'rotor_torque'), ('dipole', 'dipole'),
                                  (WHEEL_COMMAND_TOPIC, 'wheel_torque'))
            if name in inputs)
        #: The node's own sim clock (``publish_clock``, ``lockstep``), or ``None``.
        self.sim_clock: SimClock | None = None
        self.tick_period = 1.0 / values['publish_rate']
        self._work = self._simulated = self._lag = 0.0
        #: Command messages used (a WrenchStamped is one, whatever fields the scene takes).
        self.commands_accepted = 0
        #: The simulated sensors of the scene's ``sensors`` section, or None.
        self.sensors: SensorSampler | None = None
        sensors = simulated_sensors(scene, self.propagator, sink, scene.magnetic_field)
        if sensors:
            self.sensors = SensorSampler(sensors, self.propagator, self.time_base)
            self.clock.advance = self.sensors.advance_to
        super().__init__(scene, values, sink, clock_ns, monotonic)

    def apply(self, values: Mapping[str, Any]) -> None:
        """Take the run-time parameters."""
        super().apply(values)
        self.clock.time_jump_threshold = values['time_jump_threshold']
        if self.sensors is not None:
            self.sensors.set_world_frame(values['world_frame'])

    def check(self, values: Mapping[str, Any]) -> str:
        """The parameters' own checks, and a clock jump within the steps of one tick."""
        return check_values(values, self.scene.step, MAX_STEPS_PER_CALL)

    # -- inputs -----------------------------------------------------------------------------

    def wrench(self, sec: int, nanosec: int, force: Sequence[float],
               torque: Sequence[float]) -> None:
        """A commanded wrench (force [N] and torque [N m], body axes) stamped ``(sec,
        nanosec)``; a bad field rejects the whole message."""
        stamp_ns = self._command_ns('torque', sec, nanosec)
        if stamp_ns is None:
            return
        vectors = {'torque': torque, 'force': force}
        bad = [name for name in self.wrench_inputs if self.commands.check(vectors[name])]
        for name in bad[:1] or self.wrench_inputs:
            if not self._command(name, stamp_ns, vectors[name]):
                return
        self.commands_accepted += 1

    def rotor_torque(self, sec: int, nanosec: int, torque: Sequence[float]) -> None:
        """A commanded motor torque on the rotor [N m] stamped ``(sec, nanosec)``."""
        stamp_ns = self._command_ns('rotor_torque', sec, nanosec)
        if stamp_ns is not None and self._command('rotor_torque', stamp_ns, torque):
            self.commands_accepted += 1

    def dipole(self, sec: int, nanosec: int, dipole_body: Sequence[float]) -> None:
        """The magnetorquers' commanded dipole [A m², body axes] stamped ``(sec, nanosec)``."""
        stamp_ns = self._command_ns('dipole', sec, nanosec)
        if stamp_ns is not None and self._command('dipole', stamp_ns, dipole_body):
            self.commands_accepted += 1

    def wheel_command(self, sec: int, nanosec: int, names: Sequence[str],
                      position: Sequence[float], velocity: Sequence[float],
                      effort: Sequence[float]) -> None:
        """A JointState for the reaction wheels (:mod:`~.actuators`: motor torques in
        ``effort`` or speeds in ``velocity``) stamped ``(sec, nanosec)``."""
        wheels = self.wheels
        stamp_ns = self._command_ns(WHEEL_COMMAND_TOPIC, sec, nanosec)
        if stamp_ns is None or wheels is None:
            return
        input_name, reason, detail, values = wheels.command(names, position, velocity, effort)
        if reason:
            self.rejections[reason] += 1
            self.warn(reason, f'{WHEEL_COMMAND_TOPIC}: {reason}: {detail}; message ignored')
        elif self._command(input_name, stamp_ns, values, WHEEL_COMMAND_TOPIC):
            self.commands_accepted += 1

    def _command_ns(self, topic: str, sec: int, nanosec: int) -> int | None:
        """The command's time: its stamp, or the receive time (no header stamps, zero
        stamp); None (counted) for an invalid stamp."""
        # In lockstep the zero stamp is a real one: the first tick's, t_0 = 0.
        if self.use_header_stamps and (sec or nanosec or self.commands.tick_ns is not None):
            problem = stamp_problem(sec, nanosec)
            if not problem:
                return to_ns(sec, nanosec)
            self.rejections['invalid_stamp'] += 1
            self.warn('invalid_stamp', f'{topic}: an invalid header stamp ({problem}); message '
                                       f'ignored (parameter `use_header_stamps`)')
            return None
        return self.clock_ns()

    def _command(self, name: str, stamp_ns: int, value: Sequence[float], key: str = '') -> bool:
        commands, time_base = self.commands, self.time_base
        # A bad value is refused as such (by add) whatever its stamp; a good one's stamp first.
        refused = None if commands.check(value) else commands.timing(
            stamp_ns, self.clock_ns(), time_base.epoch_ns if self.clock.started else None,
            seconds_to_ns(self.clock.time_jump_threshold))
        time_s = time_base.seconds(stamp_ns) if time_base.started else math.nan
        outcome = refused or commands.add(name, stamp_ns, time_s, value, key)
        if outcome.reason:
            self.warn(outcome.reason, f'{name}: {_DETAIL[outcome.reason]}')
        return outcome.accepted

    # -- ticks ------------------------------------------------------------------------------

    def tick(self, now_ns: int) -> None:
        """Integrate up to the clock time ``now_ns`` and hand every output to the sink."""
        propagator, clock = self.propagator, self.clock
        before, started = propagator.state.time, self.monotonic()
        starting = not clock.started
        self._tick_ns = now_ns
        try:
            outcome = clock.tick(0.0 if starting else self.time_base.seconds(now_ns))
        except AttitudeError as err:  # the integrator refused the step; the state is intact
            self._restart('integration_failed', f'integration refused at '
                                                f't={propagator.state.time:.6f} s: {err}')
            return
        if outcome.integrated:
            self._work += self.monotonic() - started
            self._simulated += propagator.state.time - before
            if self.commands.tick_ns is None:  # (lockstep: the ticks are the clock, no lag)
                lag = self.time_base.seconds(self.clock_ns()) - propagator.state.time
                self._lag = max(self._lag, lag)
        if outcome.reason:
            self._clock_rejected(outcome)
        if self.sensors is not None and (outcome.reset or starting and outcome.accepted):
            self.sensors.advance_to(propagator.state.time)  # the samples due at the start
        if outcome.moved:
            self._publish()

    def _scene_start(self, now: float) -> float:
        """The scene (re)starts at this tick: scene time 0 at its clock time."""
        return self.time_base.start(self._tick_ns)

    def lockstep_tick(self, now_ns: int) -> None:
        """Lockstep: tick ``now_ns`` of the sim clock, then wait for the commands stamped
        with it (:meth:`lockstep_answered`)."""
        self.tick(now_ns)
        self.commands.tick_ns = now_ns

    def republish(self) -> None:
        """The outputs of the current state again, the simulated sensors' last samples first
        (lockstep's first tick, until answered: a controller that subscribed late gets the
        magnetometer sample it waits for too)."""
        if self.clock.started:
            if self.sensors is not None:
                self.sensors.resend()
            self._publish()

    def lockstep_answered(self) -> bool:
        """Lockstep: every commanded input has its command for the current tick (or the
        scene starts again at the next: a reset)."""
        return not self.clock.started or self.commands.answered(self.command_inputs)

    def _publish(self) -> None:
        sample = self.tracker.sample(self.propagator)
        if not _finite(sample):
            self._restart('non_finite_result', 'integration gave a non-finite state')
            return
        sec, nanosec = split_ns(self.time_base.nanoseconds(sample.stamp))
        self.sink.dynamics(sec, nanosec, sample, body_frame_velocity(self.propagator))
        self.sink.invariants(sec, nanosec, sample.energy, sample.world_momentum)
        wheels = self.wheels
        if wheels is not None:
            self.sink.wheel_state(wheels.state(sec, nanosec))
            news = wheels.speed_limit_news()
            if news:
                self.note('speed_limit', news, sum(wheels.effect.speed_limit_episodes))

    def _clock_rejected(self, outcome: Outcome) -> None:
        if outcome.reset:
            self.commands.reset()
            if self.sensors is not None:
                self.sensors.reset()
            self.sink.log(LEVEL_WARN, f'clock: time jumped back by more than '
                                      f'time_jump_threshold ({self.clock.time_jump_threshold:g}'
                                      f' s; looping bag?); reset to the initial state of scene '
                                      f'{self.scene.name!r}')
        elif outcome.reason == 'gap':
            self.warn('gap', 'clock: a jump longer than time_jump_threshold; not integrated '
                             'across, attitude held (parameter `time_jump_threshold`)')
        else:
            self.warn(outcome.reason, f'clock: {outcome.reason}; tick ignored')

    def _restart(self, reason: str, text: str) -> None:
        """Count a refused integration, log it and restart the scene at the next tick."""
        self.rejections[reason] += 1
        self.error(f'{text}; reset to the initial state of scene {self.scene.name!r} '
                   f'(parameters `integrator`, `step`)')
        self.reset()

    def reset(self) -> None:
        """The scene's initial state; the next tick restarts it at the clock's time."""
        self.clock.reset()
        self.propagator.reset(self.propagator.state.time)
        self.commands.reset()
        if self.sensors is not None:
            self.sensors.reset()

    def resume(self) -> None:
        """The state kept; the next tick is a new baseline (the scene paused meanwhile)."""
        self.clock.resume()

    def _pose_set(self, orientation_covariance: tuple[float, ...] | None) -> None:
        """A pose was set: the simulated IMU's next sample instant is a new baseline (the
        point samples go on from the next instant not yet sampled)."""
        if self.sensors is not None:
            self.sensors.restart()

    # -- counts -----------------------------------------------------------------------------

    def accepted_count(self) -> int:
        """Commands and poses used so far (clock ticks are not inputs)."""
        return self.commands_accepted + self.poses_accepted

    def _stream_rejections(self) -> list[Counter[str]]:
        return [self.commands.rejected, self.clock.rejected]

    def _input_rejections(self) -> list[Counter[str]]:
        return [self.commands.rejected]

    def _timing(self, counts: PeriodCounts) -> None:
        counts.real_time_factor = (self._simulated / self._work if self._work > 0.0
                                   else math.inf)
        counts.lag, counts.tick_period = self._lag, self.tick_period
        if self.sim_clock is not None:
            self.sim_clock.report(counts)
        _actuator_counts(counts, self.wheels, self.rods, self.rejections)
        self._work = self._simulated = self._lag = 0.0


def _actuator_counts(counts: PeriodCounts, wheels: WheelArray | None,
                     rods: MagnetorquerReport | None, rejections: Counter[str]) -> None:
    """The wheels' and the rods' lines of the period's report."""
    if wheels is not None:
        values, problems = wheels.report()
        counts.actuator_values += tuple(values) + tuple(
            (f'rejected {reason}', str(rejections[reason])) for reason in WHEEL_REASONS)
        counts.actuator_problems += tuple(problems)
    if rods is not None:
        counts.actuator_values += tuple(rods.values())


def _finite(sample: OutputSample) -> bool:
    values = (*sample.attitude, *sample.position, *sample.omega_body, sample.energy,
              *sample.world_momentum)
    # a NaN or an infinity makes the sum non-finite; a finite sum settles it in one call
    return math.isfinite(sum(values)) or all(math.isfinite(value) for value in values)
