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

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.errors import SceneError
from rigid_body_attitude.inertia import Inertia

__all__ = [
    'BodyProperties',
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
    """A commanded vector held from its stamp until ``timeout`` seconds later, then zero.

    Each command that expires without a newer one counts once as ``stale`` on the owning
    effect, so the diagnostics can report stale torques.
    """

    def __init__(self, owner: Effect, timeout: float) -> None:
        """Hold commands for ``timeout`` [s]; count expiries on ``owner``."""
        self.owner = owner
        self.timeout = timeout
        self.reset()

    def reset(self) -> None:
        """Forget the held command."""
        self.value = np.zeros(3)
        self.stamp = -np.inf
        self.expired = True

    def set(self, t: float, value: FloatArray) -> None:
        """Hold ``value`` from time ``t``."""
        self.value = np.array(value, dtype=np.float64)
        self.stamp = float(t)
        self.expired = False

    def active(self, t: float) -> bool:
        """Whether the command is still held at ``t``; counts an expiry once."""
        if t - self.stamp <= self.timeout:
            return True
        if not self.expired:
            self.expired = True
            self.owner.count('stale')
        return False

    def value_at(self, t: float) -> FloatArray:
        """The held command at ``t``, or zero after the timeout."""
        return self.value if self.active(t) else np.zeros(3)
