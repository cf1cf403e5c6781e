"""What a propagator publishes, computed once for the node and the replay tool alike.

:class:`OutputTracker` turns the propagator's state into an :class:`OutputSample`: the attitude
made continuous with the previous output (``q · q_prev ≥ 0``, see
:mod:`rigid_body_attitude.core.attitude.quaternion`) and renormalised, the position, the body rate,
the
kinetic energy and the world angular momentum. The node converts a sample to messages; the
replay tool writes the same messages to a bag, so both give the same numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator

__all__ = ['OutputSample', 'OutputTracker', 'StampRateLimiter']

Vector = tuple[float, float, float]


@dataclass(frozen=True)
class OutputSample:
    """One set of published values.

    Attributes:
        stamp: propagated time [s].
        attitude: unit quaternion (w, x, y, z), body → world, continuous with the last output.
        position: centre of mass in the world frame [m].
        omega_body: body rate [rad/s].
        energy: kinetic energy [J].
        world_momentum: world-frame angular momentum [N m s].
    """

    stamp: float
    attitude: tuple[float, float, float, float]
    position: Vector
    omega_body: Vector
    energy: float
    world_momentum: Vector


class OutputTracker:
    """Keeps the last published attitude so consecutive outputs never flip sign."""

    def __init__(self) -> None:
        """No output yet."""
        self.previous: tuple[float, float, float, float] | None = None

    def attitude(self, propagator: DynamicsPropagator | GyroPropagator
                 ) -> tuple[float, float, float, float]:
        """The propagator's attitude, unit-norm and on the side of the previous output."""
        w, x, y, z = propagator.state.attitude_tuple()
        scale = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
        previous = self.previous
        if previous is not None and (w * previous[0] + x * previous[1] + y * previous[2]
                                     + z * previous[3]) < 0.0:
            scale = -scale
        self.previous = (w * scale, x * scale, y * scale, z * scale)
        return self.previous

    def sample(self, propagator: DynamicsPropagator | GyroPropagator) -> OutputSample:
        """Everything published for the propagator's current state."""
        state = propagator.state
        return OutputSample(
            stamp=state.time,
            attitude=self.attitude(propagator),
            position=tuple(state.position.tolist()),
            omega_body=state.omega_tuple(),
            energy=propagator.energy(),
            world_momentum=propagator.world_momentum_tuple(),
        )


class StampRateLimiter:
    """At most ``rate_hz`` events per second of stamps, and that many when the stamps allow.

    Events are due on a grid of period ``1 / rate_hz`` started at the first stamp: a stamp at
    or past the next grid point is let through and the grid moves on by one period (not to
    that stamp plus a period, which would lose a slot to every late stamp: a 200 Hz input with
    jittered stamps would give about 77 instead of 100 transforms per second). A stamp more
    than a period past its grid point (a gap) restarts the grid at it; a stamp before the last
    one let through (the stamps went back) is let through and restarts the grid too. Rate 0:
    every stamp.
    """

    def __init__(self, rate_hz: float) -> None:
        self.period_ns = round(1e9 / rate_hz) if rate_hz > 0.0 else 0
        self._due_ns = self._last_ns = 0
        self._started = False

    def due(self, stamp_ns: int) -> bool:
        """Whether an event at ``stamp_ns`` [ns] is let through (and counted as sent)."""
        due_ns, period_ns = self._due_ns, self.period_ns
        if self._started and self._last_ns <= stamp_ns < due_ns:
            return False
        on_grid = self._started and self._last_ns <= due_ns <= stamp_ns < due_ns + period_ns
        self._due_ns = (due_ns if on_grid else stamp_ns) + period_ns
        self._last_ns, self._started = stamp_ns, True
        return True
