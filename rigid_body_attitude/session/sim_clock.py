"""The node's own sim clock: ticks of simulated time, their pacing against wall time, lockstep.

With ``publish_clock`` or ``lockstep`` a dynamics scene does not follow a clock, it is one:
tick ``k`` is at sim time ``t_k = k P`` (``P`` the tick period of ``publish_rate``, ``t_0 =
0``), due at wall time ``w_0 + t_k / real_time_factor`` on the monotonic clock (at once with
factor 0). A loop that falls more than one period behind that schedule (a slow controller)
moves the schedule rather than catching up in a burst.

Lockstep (docs/closed-loop.md): after the outputs of tick ``k`` the clock waits for the
commands stamped ``t_k`` (:meth:`~.stream.CommandStream.answered`) before tick ``k + 1``. A
controller silent for ``lockstep_timeout`` wall seconds is warned about once per silence,
counted (``lockstep_timeouts`` in ``/diagnostics``), and the tick advances with the last
command held (as the scene holds commands: ``torque_timeout``). Everything here is plain
Python on injected clocks; the waiting itself is the ROS loop's
(:mod:`rigid_body_attitude.ros.step_loop`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.session.base import OutputSink
from rigid_body_attitude.session.reports import LEVEL_WARN, PeriodCounts

__all__ = ['SimClock', 'sim_clock_for', 'sim_clock_problem', 'uses_sim_clock']


def uses_sim_clock(values: Mapping[str, Any]) -> bool:
    """Whether the parameters make the node its own clock (``publish_clock`` or
    ``lockstep``)."""
    return bool(values.get('publish_clock') or values.get('lockstep'))


def sim_clock_for(values: Mapping[str, Any], period_ns: int,
                  monotonic: Callable[[], float]) -> SimClock | None:
    """The sim clock the parameters ask for (ticks every ``period_ns``), or ``None``."""
    if not uses_sim_clock(values):
        return None
    return SimClock(period_ns, values['real_time_factor'], values['lockstep'],
                    values['lockstep_timeout'], monotonic)


def sim_clock_problem(values: Mapping[str, Any], scene: Scene,
                      command_inputs: tuple[str, ...]) -> str:
    """Why the sim-clock parameters do not fit the scene, or ``''``."""
    if not uses_sim_clock(values):
        return ''
    if scene.rate_source != 'dynamics':
        return (f'Expected a dynamics scene with `publish_clock` or `lockstep`; scene '
                f'{scene.name!r} integrates gyro samples (their stamps are its clock)')
    if values.get('lockstep') and not command_inputs:
        return (f'Expected a scene with commanded inputs (torque, force, rotor_torque) for '
                f'`lockstep`; scene {scene.name!r} takes none')
    return ''


class SimClock:
    """Sim time ticks, their wall-time schedule, lockstep timeouts and the achieved factor."""

    def __init__(self, period_ns: int, real_time_factor: float, lockstep: bool,
                 lockstep_timeout: float, monotonic: Callable[[], float]) -> None:
        """Ticks every ``period_ns`` of sim time, paced at ``real_time_factor`` (0: unpaced)
        on ``monotonic`` [s]; with ``lockstep`` waiting at most ``lockstep_timeout`` wall
        seconds for each tick's commands."""
        self.period_ns = period_ns
        self.real_time_factor = real_time_factor
        self.lockstep = lockstep
        self.lockstep_timeout = lockstep_timeout
        self.monotonic = monotonic
        #: Sim time of the last tick [ns] (0 before the first).
        self.now_ns = 0
        #: Index of the next tick.
        self.next_index = 0
        #: Ticks advanced without their commands (lockstep), so far.
        self.timeouts = 0
        #: Waiting for a controller's first command, at the first tick (lockstep).
        self.waiting = False
        self._silent = False
        self._timeouts_reported = 0
        self._schedule_start: float | None = None
        self._period_start: tuple[int, float] | None = None

    def now(self) -> int:
        """Sim time [ns] (the session's clock)."""
        return self.now_ns

    def next_tick(self) -> int:
        """Advance to the next tick; its sim time [ns]."""
        wall = self.monotonic()
        if self._schedule_start is None:
            self._schedule_start = wall
            self._period_start = (0, wall)
        self.now_ns = self.next_index * self.period_ns
        self.next_index += 1
        return self.now_ns

    def seconds_to_next(self) -> float:
        """Wall seconds until the next tick is due (``<= 0``: it is due)."""
        factor, start = self.real_time_factor, self._schedule_start
        if factor <= 0.0 or start is None:
            return 0.0
        wall = self.monotonic()
        wall_per_tick = self.period_ns * 1e-9 / factor
        due = start + self.next_index * wall_per_tick
        if wall - due > wall_per_tick:  # behind by more than a tick: move the schedule
            self._schedule_start = start + (wall - due)
            return 0.0
        return due - wall

    def timed_out(self, sink: OutputSink) -> None:
        """Lockstep: no commands for the current tick within ``lockstep_timeout``; counted,
        warned about once per silence."""
        self.timeouts += 1
        if not self._silent:
            self._silent = True
            sink.log(LEVEL_WARN, f'lockstep: no command stamped t={self.now_ns * 1e-9:.9f} s '
                                 f'within lockstep_timeout ({self.lockstep_timeout:g} s of wall '
                                 f'time); holding the last command and advancing (counted as '
                                 f'lockstep_timeouts in /diagnostics; this warning is not '
                                 f'repeated until the controller answers again)')

    def answered(self) -> None:
        """Lockstep: the current tick's commands arrived (a silence ends)."""
        self._silent = False

    def report(self, counts: PeriodCounts) -> None:
        """The clock's values and problems for the diagnostics period that ends."""
        wall = self.monotonic()
        factor = math.nan
        if self._period_start is not None:
            start_ns, start_wall = self._period_start
            if wall > start_wall:
                factor = (self.now_ns - start_ns) * 1e-9 / (wall - start_wall)
            self._period_start = (self.now_ns, wall)
        values = [('sim_time [s]', f'{self.now_ns * 1e-9:.9f}'),
                  ('achieved_real_time_factor', f'{factor:.3g}'),
                  ('target_real_time_factor', f'{self.real_time_factor:g}')]
        problems = []
        if self.lockstep:
            values.append(('lockstep_timeouts', str(self.timeouts)))
            new = self.timeouts - self._timeouts_reported
            self._timeouts_reported = self.timeouts
            if new:
                problems.append(f'lockstep: {new} ticks advanced without their command in the '
                                f'last period (parameter `lockstep_timeout`)')
            if self.waiting:
                problems.append('lockstep: waiting for a controller to answer the first tick '
                                '(t=0) on the command topics')
        counts.clock_values = tuple(values)
        counts.clock_problems = tuple(problems)
