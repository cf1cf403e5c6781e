"""The effect protocol: small classes the propagator sums without knowing any of them.

An effect is named in a scene file with its parameters; only the effects a scene names are
constructed and evaluated. Each effect class declares its parameters (:class:`Parameter`), the
scene kinds it applies to (``rate_sources``) and the commanded inputs it listens to
(``inputs``), and implements one or more of these capabilities (Basilisk's split between
dynamic effectors and effectors with state of their own):

* ``torque_body(t, attitude, omega_body) -> (3,)`` [N m, body] — a torque effect;
* ``rotor_momentum(t) -> (h, ḣ)`` [N m s, N m; body] — a gyrostat rotor;
* ``force_world(t, attitude) -> (3,)`` [N, world] — a force on the centre of mass;
* ``corrected_rate(t, attitude, omega_measured) -> (3,)`` [rad/s, body] — a correction of
  measured gyro rates (strapdown scenes);
* :class:`StatefulEffect` — carries an integrated state of its own (centre-of-mass motion).

The registry maps scene names to classes; modules in this package register themselves on
import, so adding an effect means adding a module, never editing the propagator.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.inertia import Inertia

__all__ = [
    'BodyProperties',
    'CommandedEffect',
    'Effect',
    'EFFECTS',
    'HeldInput',
    'Parameter',
    'REQUIRED',
    'boolean',
    'StatefulEffect',
    'nonnegative',
    'positive',
    'real',
    'register',
    'vector3',
]

FloatArray = NDArray[np.float64]

_ZERO3 = np.zeros(3)

#: Marks a parameter without default.
REQUIRED: Any = object()

#: Scene effect name → effect class; filled by :func:`register`.
EFFECTS: dict[str, type[Effect]] = {}


@dataclass(frozen=True)
class BodyProperties:
    """What an effect may know about the body: inertia [kg m²] and mass [kg]."""

    inertia: Inertia
    mass: float


@dataclass(frozen=True)
class Parameter:
    """One effect parameter: a converter that validates, a default, and a description.

    ``default`` of :data:`REQUIRED` makes the parameter required. The converter receives the raw
    value and returns the checked one or raises ``ValueError``/``TypeError`` with a reason.
    """

    convert: Callable[[Any], Any]
    default: Any
    description: str


def real(value: Any) -> float:
    """A finite real number (booleans and strings are refused)."""
    if isinstance(value, str) and _looks_numeric(value):
        raise TypeError(f'a number (YAML 1.1 reads {value} as text: write it with a sign in '
                        f'the exponent and a dot, e.g. 7.0e+6)')
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError('a number')
    number = float(value)
    if not np.isfinite(number):
        raise ValueError('a finite number')
    return number


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def positive(value: Any) -> float:
    """A finite number > 0."""
    number = real(value)
    if number <= 0.0:
        raise ValueError('a number > 0')
    return number


def nonnegative(value: Any) -> float:
    """A finite number >= 0."""
    number = real(value)
    if number < 0.0:
        raise ValueError('a number >= 0')
    return number


def vector3(value: Any) -> FloatArray:
    """A list of three finite numbers."""
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise TypeError('a list of 3 numbers')
    return np.array([real(item) for item in value])


def boolean(value: Any) -> bool:
    """``true`` or ``false``."""
    if not isinstance(value, bool):
        raise TypeError('true or false')
    return value


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator adding an effect to :data:`EFFECTS` under ``cls.name``."""
    if cls.name in EFFECTS:
        raise SceneError(f'Effect name {cls.name!r} is registered twice')
    EFFECTS[cls.name] = cls
    return cls


class Effect:
    """Base of every effect: validated parameters, scene kinds, commanded inputs, counters.

    Subclasses set ``name``, ``description``, ``parameters``, ``rate_sources``, ``requires``
    (names of other effects the scene must also name) and, when they listen to a commanded
    input, ``inputs`` (input name → description) and :meth:`accept_input`. A torque effect
    whose ``torque_body`` uses ``omega_body`` sets ``torque_depends_on_rate`` True: otherwise
    the splitting integrators apply its torque as an exact one-evaluation kick.
    """

    name: ClassVar[str] = ''
    description: ClassVar[str] = ''
    parameters: ClassVar[Mapping[str, Parameter]] = {}
    rate_sources: ClassVar[frozenset[str]] = frozenset({'dynamics'})
    inputs: ClassVar[Mapping[str, str]] = {}
    requires: ClassVar[tuple[str, ...]] = ()
    torque_depends_on_rate: ClassVar[bool] = False

    def __init__(self, params: Mapping[str, Any], body: BodyProperties) -> None:
        """Validate ``params`` against :attr:`parameters`; keep ``body``."""
        self.body = body
        self.params = validate_parameters(self.name, self.parameters, params)
        self.counters: dict[str, int] = {}

    def reset(self) -> None:
        """Return to the state at construction (held commands cleared)."""

    @property
    def input_names(self) -> frozenset[str]:
        """Commanded inputs this instance listens to (a subset of :attr:`inputs`)."""
        return frozenset(self.inputs)

    def count(self, reason: str) -> None:
        """Add one to the counter ``reason`` (reported in the diagnostics)."""
        self.counters[reason] = self.counters.get(reason, 0) + 1

    def accept_input(self, input_name: str, t: float, value: FloatArray) -> None:
        """Take a commanded input (only called for names in :attr:`inputs`)."""
        raise SceneError(f'Effect {self.name!r} takes no input {input_name!r}')


class StatefulEffect(Effect):
    """An effect with an integrated state of its own, advanced by the propagator each step.

    ``advance`` receives the attitude at both ends of the step and a function summing the
    scene's forces; it returns the work [J] those forces did over the step.
    """

    def advance(self, t: float, h: float, attitude_start: FloatArray,
                attitude_end: FloatArray,
                force_world: Callable[[float, FloatArray], FloatArray]) -> float:
        """Advance the own state from ``t`` to ``t + h``; return the work done [J]."""
        raise SceneError(f'Effect {self.name!r} does not define advance()')

    def kinetic_energy(self) -> float:
        """Kinetic energy [J] stored in the own state."""
        return 0.0

    def outputs(self) -> dict[str, FloatArray]:
        """Named vectors of the own state for publishing (e.g. ``position``)."""
        return {}


def validate_parameters(effect_name: str, spec: Mapping[str, Parameter],
                        params: Mapping[str, Any]) -> dict[str, Any]:
    """Check ``params`` against ``spec``: unknown names, missing keys and bad values.

    Raises :class:`SceneError` naming the effect, the parameter, the value and the valid
    choices.
    """
    if not isinstance(params, Mapping):
        raise SceneError(f'Effect {effect_name!r}: expected a mapping of parameters, '
                         f'got {params!r}')
    valid = ', '.join(sorted(spec)) or '(none)'
    unknown = sorted(set(params) - set(spec))
    if unknown:
        raise SceneError(f'Effect {effect_name!r}: unknown parameter {unknown[0]!r}; '
                         f'valid parameters: {valid}')
    checked = {}
    for key, parameter in spec.items():
        if key not in params:
            if parameter.default is REQUIRED:
                raise SceneError(f'Effect {effect_name!r}: missing parameter {key!r} '
                                 f'({parameter.description}); valid parameters: {valid}')
            checked[key] = parameter.convert(parameter.default)
            continue
        try:
            checked[key] = parameter.convert(params[key])
        except (TypeError, ValueError) as err:
            raise SceneError(f'Effect {effect_name!r}: parameter {key!r} must be {err}, '
                             f'got {params[key]!r}') from err
    return checked


class HeldInput:
    """Commanded vectors, each held from its stamp until ``timeout`` seconds later, then zero.

    The commands form a piecewise-constant function of time: a newer command ends the previous
    one at its own stamp, and a command stamped ahead of the propagated time takes effect only
    at its stamp. :meth:`switch_times` lists where the function jumps, so the propagator can
    end a step exactly there; during a step, :meth:`begin_step` pins the evaluation to the
    command in force inside the step (its midpoint decides), so the integrator's stages at the
    step's end points never see the other side of a jump. Each command that expires without a
    newer one counts once as ``stale`` on the owning effect.
    """

    #: Commands kept; older ones can no longer be in force once this many newer ones exist.
    KEPT = 8

    def __init__(self, owner: Effect, timeout: float) -> None:
        """Hold commands for ``timeout`` [s]; count expiries on ``owner``."""
        self.owner = owner
        self.timeout = timeout
        self.reset()

    def reset(self) -> None:
        """Forget every command."""
        self.segments: list[tuple[float, float, FloatArray]] = []
        self.folded = np.zeros(3)
        self.window: float | None = None
        self.expiry_counted = True

    @property
    def value(self) -> FloatArray:
        """The latest command (zero before any)."""
        return self.segments[-1][2] if self.segments else np.zeros(3)

    @property
    def stamp(self) -> float:
        """Stamp of the latest command (−inf before any)."""
        return self.segments[-1][0] if self.segments else -math.inf

    def set(self, t: float, value: FloatArray) -> None:
        """Hold ``value`` from time ``t`` (ending the previous command there)."""
        t = float(t)
        while self.segments and self.segments[-1][0] >= t:
            self.segments.pop()
        if self.segments and self.segments[-1][1] > t:
            start, _, previous = self.segments[-1]
            self.segments[-1] = (start, t, previous)
        self.segments.append((t, t + self.timeout, np.array(value, dtype=np.float64)))
        for start, end, old in self.segments[:-self.KEPT]:
            self.folded = self.folded + old * (end - start)
        del self.segments[:-self.KEPT]
        self.expiry_counted = False

    def switch_times(self) -> list[float]:
        """Times where the held command jumps (starts and ends of the kept commands)."""
        return [time for start, end, _ in self.segments for time in (start, end)]

    def begin_step(self, t_start: float, t_end: float) -> None:
        """Evaluate as the command in force inside ``(t_start, t_end)`` until :meth:`end_step`."""
        self.window = 0.5 * (t_start + t_end)

    def end_step(self) -> None:
        """Evaluate at the times asked again."""
        self.window = None

    def segment_at(self, t: float) -> tuple[float, float, FloatArray] | None:
        """The command in force at ``t`` (the step's midpoint during a step), or None."""
        probe = t if self.window is None else self.window
        for segment in reversed(self.segments):
            if segment[0] <= probe:
                if probe <= segment[1]:
                    return segment
                break
        if self.segments and probe > self.segments[-1][1] and not self.expiry_counted:
            self.expiry_counted = True
            self.owner.count('stale')
        return None

    def active(self, t: float) -> bool:
        """Whether a command is in force at ``t``; counts an expiry once."""
        return self.segment_at(t) is not None

    def value_at(self, t: float) -> FloatArray:
        """The command in force at ``t``, or zero."""
        segment = self.segment_at(t)
        return _ZERO3 if segment is None else segment[2]

    def integral(self, t: float) -> FloatArray:
        """``∫ command dt`` from the first command to ``t`` (exact for the piecewise constant)."""
        total = self.folded
        for start, end, value in self.segments:
            if t <= start:
                break
            total = total + value * (min(t, end) - start)
        return total


class CommandedEffect(Effect):
    """An effect driven by one commanded input held in a :class:`HeldInput`.

    Subclasses declare a ``timeout`` parameter and one entry in ``inputs``; this base keeps the
    commands and tells the propagator where they switch (:meth:`switch_times`) and which
    command is in force during a step (:meth:`begin_step`, :meth:`end_step`).
    """

    def __init__(self, params: Mapping[str, Any], body: BodyProperties) -> None:
        """Validate the parameters; no command is held initially."""
        super().__init__(params, body)
        self.command = HeldInput(self, self.params['timeout'])

    def reset(self) -> None:
        """Drop every held command."""
        self.command.reset()

    def accept_input(self, input_name: str, t: float, value: FloatArray) -> None:
        """Hold ``value`` from ``t``."""
        self.command.set(t, value)

    def switch_times(self) -> list[float]:
        """Times where the commanded input jumps."""
        return self.command.switch_times()

    def begin_step(self, t_start: float, t_end: float) -> None:
        """Evaluate with the command in force inside the step."""
        self.command.begin_step(t_start, t_end)

    def end_step(self) -> None:
        """Evaluate at the times asked again."""
        self.command.end_step()
