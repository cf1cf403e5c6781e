"""Effect kinds: small classes the propagator combines without knowing any particular one.

An effect is named in a scene file with its parameters; only the effects a scene names are
constructed and evaluated. Each effect class declares its parameters (:class:`Parameter`), the
scene kinds it applies to (``rate_sources``) and the commanded inputs it listens to
(``inputs``), and says what it provides by the kinds it derives from (Basilisk's split between
dynamic effectors and effectors with state of their own):

* :class:`TorqueEffect` — ``torque(t, q, ω) -> (M₁, M₂, M₃)`` [N m, body], plain floats;
* :class:`RotorEffect` — ``rotor(t) -> ((h₁, h₂, h₃), (ḣ₁, ḣ₂, ḣ₃))`` [N m s, N m; body];
* :class:`ForceEffect` — ``force(t, q) -> (F₁, F₂, F₃)`` [N, world] on the centre of mass;
* :class:`RateCorrection` — ``corrected_rate(t, attitude, ω_measured)`` [rad/s, body] for
  measured gyro rates (strapdown scenes);
* :class:`StatefulEffect` — an integrated state of its own (centre-of-mass motion);
* :class:`~.held.HeldOverStep` — an output held over each integration step, evaluated from
  the state at the step's start (a drive's or a coil's zero-order hold at the scene's step);
* :class:`~.held.RotorState` — rotors whose speeds are an integrated state of their own
  (reaction wheels): a :class:`RotorEffect` held over each step, its spin inertia taken out of
  the body's;
* :class:`CommandedEffect` — driven by a held commanded input whose switch times end steps;
* :class:`~.sampled.SampledTorque` — a digital controller's torque: computed from the state
  at sample instants a whole number of steps apart, held in between (zero-order hold).

Hot paths take and return plain-float tuples (``Quat`` = (w, x, y, z), ``Vec``): a NumPy call
costs about 1 µs, more than a whole torque. ``torque_body``, ``rotor_momentum`` and
``force_world`` give the same values as arrays for scripts and tests. The registry
:data:`EFFECTS` maps scene names to classes; modules in this package register themselves on
import (``@register``), so adding an effect means adding a module, never editing the
propagator.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.dynamics.batch_rows import BatchChunk
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.environment.magnetic_field import MagneticFieldModel
from rigid_body_attitude.core.environment.orbit import CircularOrbit
from rigid_body_attitude.core.registry import Registry
from rigid_body_attitude.core.yaml_files import real

__all__ = [
    'BatchChunk',
    'BodyProperties',
    'CommandedEffect',
    'ConservativeTorque',
    'Effect',
    'EFFECTS',
    'ForceEffect',
    'Environment',
    'HeldInput',
    'Parameter',
    'Quat',
    'REQUIRED',
    'RateCorrection',
    'RotorEffect',
    'StatefulEffect',
    'TorqueEffect',
    'Vec',
    'boolean',
    'nonnegative',
    'positive',
    'real',
    'register',
    'vector3',
]

FloatArray = NDArray[np.float64]
Quat = tuple[float, float, float, float]
Vec = tuple[float, float, float]

_ZERO: Vec = (0.0, 0.0, 0.0)

#: Marks a parameter without default.
REQUIRED: Any = object()

#: Scene effect name → effect class; filled by :func:`register`.
EFFECTS: Registry[type[Effect]] = Registry('effect', SceneError)


@dataclass(frozen=True)
class Environment:
    """What a scene says about the world the body moves in, for the effects that act through
    it: the orbit and the magnetic field model (``core/environment``), each None when the
    scene has no such section."""

    orbit: CircularOrbit | None = None
    magnetic_field: MagneticFieldModel | None = None

    def required_field(self, effect: str) -> MagneticFieldModel:
        """The magnetic field model, for an effect that acts through it; SceneError naming
        ``effect`` when the scene has no ``magnetic_field:`` section."""
        if self.magnetic_field is None:
            raise SceneError(f"Effect {effect!r} needs the scene's magnetic_field: section")
        return self.magnetic_field


_NO_ENVIRONMENT = Environment()


@dataclass(frozen=True)
class BodyProperties:
    """What an effect may know about the body, inertia [kg m²] (the whole body, rotors
    locked) and mass [kg], and about the scene's :class:`Environment`."""

    inertia: Inertia
    mass: float
    environment: Environment = _NO_ENVIRONMENT


@dataclass(frozen=True)
class Parameter:
    """One effect parameter: a converter that validates, a default, and a description.

    ``default`` of :data:`REQUIRED` makes the parameter required. The converter receives the raw
    value and returns the checked one or raises ``ValueError``/``TypeError`` with a reason.
    """

    convert: Callable[[Any], Any]
    default: Any
    description: str


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


EffectClass = TypeVar('EffectClass', bound='type[Effect]')


def register(cls: EffectClass) -> EffectClass:
    """Class decorator adding an effect to :data:`EFFECTS` under ``cls.name``."""
    EFFECTS.register(cls)
    return cls


def as_quat(attitude: Sequence[float] | FloatArray) -> Quat:
    """An attitude as a plain-float (w, x, y, z) tuple."""
    w, x, y, z = np.asarray(attitude, dtype=np.float64).tolist()
    return w, x, y, z


def as_vec(vector: Sequence[float] | FloatArray) -> Vec:
    """A 3-vector as a plain-float tuple."""
    if type(vector) is tuple and len(vector) == 3 and all(type(v) is float for v in vector):
        return vector  # already one (the propagator's commands)
    x, y, z = np.asarray(vector, dtype=np.float64).tolist()
    return x, y, z


class Effect:
    """Base of every effect: validated parameters, scene kinds, commanded inputs, counters.

    Subclasses set ``name``, ``description``, ``parameters``, ``rate_sources``, ``requires``
    (names of other effects the scene must also name) and, when they listen to a commanded
    input, ``inputs`` (input name → description) and :meth:`accept_input`. What an effect
    provides is said by the kinds it derives from (module docstring).
    """

    name: ClassVar[str] = ''
    description: ClassVar[str] = ''
    parameters: ClassVar[Mapping[str, Parameter]] = {}
    rate_sources: ClassVar[frozenset[str]] = frozenset({'dynamics'})
    inputs: ClassVar[Mapping[str, str]] = {}
    requires: ClassVar[tuple[str, ...]] = ()
    #: Parameters every body of a batch shares (not dispersed per body).
    shared_parameters: ClassVar[frozenset[str]] = frozenset()
    #: Retired parameter names → the names in use (a retired name is an error naming its
    #: successor).
    renamed_parameters: ClassVar[Mapping[str, str]] = {}

    def __init__(self, params: Mapping[str, Any], body: BodyProperties) -> None:
        """Validate ``params`` against :attr:`parameters`; keep ``body``."""
        self.body = body
        self.params = validate_parameters(self.name, self.parameters, params,
                                          self.renamed_parameters)
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

    def accept_input(self, input_name: str, t: float, value: Vec | FloatArray) -> None:
        """Take a commanded input (only called for names in :attr:`inputs`)."""
        raise SceneError(f'Effect {self.name!r} takes no input {input_name!r}')

    def input_size(self, input_name: str) -> int:
        """How many numbers a command of ``input_name`` holds (3: a body vector)."""
        return 3

    def bind(self, effects: Sequence[Effect]) -> None:
        """Link to the other effects of the scene (all built), e.g. a controller to the
        actuator it drives; :class:`SceneError` when a link the parameters ask for is missing.
        """

    def check_step(self, step: float) -> None:
        """Refuse (:class:`SceneError`) a scene step [s] this effect cannot be held over."""


class TorqueEffect(Effect, ABC):
    """An effect exerting a torque ``M(t, q, ω)`` [N m] in body axes.

    ``torque_depends_on_rate`` is True when :meth:`torque` uses ``ω``; otherwise the splitting
    integrators apply the torque as an exact one-evaluation kick. :meth:`add_batch_torque`
    is the same torque for many bodies at once (:mod:`rigid_body_attitude.core.dynamics.batch`).
    """

    torque_depends_on_rate: ClassVar[bool] = False
    #: False for a controller whose output drives an actuator effect instead of the body.
    applies_torque: bool = True

    @abstractmethod
    def torque(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The torque [N m, body] at time ``t``, attitude ``q`` and body rate ``omega``."""

    @abstractmethod
    def add_batch_torque(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                         out: FloatArray) -> None:
        """Add the torque of every body of ``chunk`` to ``out`` (3, n); ``q`` is (4, n)
        (rows w, x, y, z), ``omega`` (3, n)."""

    def torque_body(self, t: float, attitude: Sequence[float] | FloatArray,
                    omega_body: Sequence[float] | FloatArray) -> FloatArray:
        """:meth:`torque` on array-likes, as a (3,) array."""
        return np.array(self.torque(t, as_quat(attitude), as_vec(omega_body)))


class ConservativeTorque(TorqueEffect, ABC):
    """A torque with a potential ``V(q)``: ``M = −∂V/∂θ`` (body-frame rotation vector θ).

    Its work over any step is ``V(q₀) − V(q₁)``, exactly: the propagator uses that for the
    energy balance instead of a quadrature of the power, so ``T − T₀ − W`` is the drift of the
    total energy ``T + V``.
    """

    @abstractmethod
    def potential(self, q: Quat) -> float:
        """Potential energy [J] at attitude ``q``."""


class RotorEffect(Effect, ABC):
    """A gyrostat rotor: momentum ``h(t)`` [N m s] relative to the body and its rate ``ḣ``."""

    @abstractmethod
    def rotor(self, t: float) -> tuple[Vec, Vec]:
        """``(h, ḣ)`` at ``t`` [N m s, N m], body axes, plain floats."""

    @abstractmethod
    def batch_rotor(self, t: float, chunk: BatchChunk) -> tuple[FloatArray, Vec]:
        """``h`` of every body of ``chunk`` ((3, n), or (3, 1) when shared) and ``ḣ``, shared
        by every body (commands reach every body alike)."""

    def rotor_momentum(self, t: float) -> tuple[FloatArray, FloatArray]:
        """:meth:`rotor` as two (3,) arrays."""
        momentum, rate = self.rotor(t)
        return np.array(momentum), np.array(rate)


class ForceEffect(Effect, ABC):
    """A force [N] on the centre of mass, world frame (needs a translation state)."""

    @abstractmethod
    def force(self, t: float, q: Quat) -> Vec:
        """The force [N, world] at time ``t`` and attitude ``q``."""

    @abstractmethod
    def add_batch_force(self, t: float, q: FloatArray, chunk: BatchChunk,
                        out: FloatArray) -> None:
        """Add the force on every body of ``chunk`` to ``out`` (3, n); ``q`` is (4, n)."""

    def force_world(self, t: float, attitude: Sequence[float] | FloatArray) -> FloatArray:
        """:meth:`force` on an array-like attitude, as a (3,) array."""
        return np.array(self.force(t, as_quat(attitude)))


class RateCorrection(Effect, ABC):
    """A correction of measured gyro rates (strapdown scenes)."""

    rate_sources: ClassVar[frozenset[str]] = frozenset({'gyro'})

    @abstractmethod
    def corrected_rate(self, t: float, attitude: FloatArray,
                       omega_measured: FloatArray) -> FloatArray:
        """The corrected body rate [rad/s] for a measurement at ``t``."""


#: Sum of the scene's forces at ``(t, q)`` [N, world], plain floats.
ForceSum = Callable[[float, Quat], Vec]


class StatefulEffect(Effect, ABC):
    """An effect with an integrated state of its own, advanced by the propagator each step.

    ``advance`` receives the attitude at both ends of the step and a function summing the
    scene's forces; it returns the work [J] those forces did over the step. An effect whose
    state includes the body's position sets ``carries_position`` and implements
    :meth:`set_position`.
    """

    carries_position: ClassVar[bool] = False

    @abstractmethod
    def advance(self, t: float, h: float, attitude_start: Quat, attitude_end: Quat,
                force_world: ForceSum) -> float:
        """Advance the own state from ``t`` to ``t + h``; return the work done [J]."""

    @abstractmethod
    def kinetic_energy(self) -> float:
        """Kinetic energy [J] stored in the own state."""

    @abstractmethod
    def outputs(self) -> dict[str, FloatArray]:
        """Named vectors of the own state for publishing (e.g. ``position``)."""

    def set_position(self, position_world: FloatArray) -> None:
        """Re-initialise the position [m, world] (effects with ``carries_position``)."""
        raise SceneError(f'Effect {self.name!r} carries no position')


def validate_parameters(effect_name: str, spec: Mapping[str, Parameter],
                        params: Mapping[str, Any],
                        renamed: Mapping[str, str] | None = None) -> dict[str, Any]:
    """Check ``params`` against ``spec``: unknown names (a retired name of ``renamed`` names
    its successor), missing keys and bad values.

    Raises :class:`SceneError` naming the effect, the parameter, the value and the valid
    choices.
    """
    if not isinstance(params, Mapping):
        raise SceneError(f'Effect {effect_name!r}: expected a mapping of parameters, '
                         f'got {params!r}')
    valid = ', '.join(sorted(spec)) or '(none)'
    unknown = sorted(set(params) - set(spec))
    retired = [name for name in unknown if renamed and name in renamed]
    if retired and renamed:
        raise SceneError(f'Effect {effect_name!r}: parameter {retired[0]!r} is named '
                         f'{renamed[retired[0]]!r}: rename it')
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
            shown = repr(params[key])
            shown = shown if len(shown) <= 100 else shown[:97] + '...'
            raise SceneError(f'Effect {effect_name!r}: parameter {key!r} must be {err}, '
                             f'got {shown}') from err
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

    def __init__(self, owner: Effect, timeout: float, size: int = 3) -> None:
        """Hold commands of ``size`` numbers (3: a body vector) for ``timeout`` [s]; count
        expiries on ``owner``. The integrals (:meth:`integral_at`) are of 3-vectors only."""
        self.owner = owner
        self.timeout = timeout
        self.size = size
        self.zero: Any = (0.0,) * size
        self.reset()

    def reset(self) -> None:
        """Forget every command."""
        self.segments: list[tuple[float, float, Any]] = []
        self.folded: Vec = _ZERO
        self.window: float | None = None
        self.pinned: tuple[float, Vec, Any] = (0.0, _ZERO, self.zero)
        self.expiry_counted = True

    @property
    def value(self) -> FloatArray:
        """The latest command (zero before any)."""
        return np.array(self.segments[-1][2] if self.segments else self.zero)

    @property
    def stamp(self) -> float:
        """Stamp of the latest command (−inf before any)."""
        return self.segments[-1][0] if self.segments else -math.inf

    def set(self, t: float, value: Sequence[float] | FloatArray) -> None:
        """Hold ``value`` from time ``t`` (ending the previous command there)."""
        t = float(t)
        while self.segments and self.segments[-1][0] >= t:
            self.segments.pop()
        if self.segments and self.segments[-1][1] > t:
            start, _, previous = self.segments[-1]
            self.segments[-1] = (start, t, previous)
        held = as_vec(value) if self.size == 3 else tuple(
            np.asarray(value, dtype=np.float64).tolist())
        self.segments.append((t, t + self.timeout, held))
        if self.size == 3:
            for start, end, old in self.segments[:-self.KEPT]:
                span = end - start
                self.folded = (self.folded[0] + old[0] * span, self.folded[1] + old[1] * span,
                               self.folded[2] + old[2] * span)
        del self.segments[:-self.KEPT]
        self.expiry_counted = False

    def switch_times(self) -> list[float]:
        """Times where the held command jumps (starts and ends of the kept commands)."""
        return [time for start, end, _ in self.segments for time in (start, end)]

    def begin_step(self, t_start: float, t_end: float) -> None:
        """Evaluate as the command in force inside ``(t_start, t_end)`` until :meth:`end_step`.

        No command starts or ends inside the interval (the propagator ends its steps at
        :meth:`switch_times`), so the command in force and the integral at its start are
        looked up once here: :meth:`vector_at` and :meth:`integral_at` then cost no search.
        """
        self.window = None
        middle = 0.5 * (t_start + t_end)
        segment = self.segment_at(middle)
        if self.size != 3:
            self.pinned = (middle, _ZERO, self.zero if segment is None else segment[2])
        elif segment is None:
            self.pinned = (middle, self.integral_at(middle), _ZERO)
        else:
            self.pinned = (segment[0], self.integral_at(segment[0]), segment[2])
        self.window = middle

    def end_step(self) -> None:
        """Evaluate at the times asked again."""
        self.window = None

    def segment_at(self, t: float) -> tuple[float, float, Any] | None:
        """The command in force at ``t`` (the step's midpoint during a step), or None."""
        probe = t if self.window is None else self.window
        for segment in reversed(self.segments):
            if segment[0] <= probe:
                if probe <= segment[1]:
                    found: tuple[float, float, Any] = segment
                    return found
                break
        if self.segments and probe > self.segments[-1][1] and not self.expiry_counted:
            self.expiry_counted = True
            self.owner.count('stale')
        return None

    def vector_at(self, t: float) -> Any:
        """The command in force at ``t``, or zero (a tuple of plain floats)."""
        if self.window is not None:
            return self.pinned[2]
        segment = self.segment_at(t)
        return self.zero if segment is None else segment[2]

    def integral_at(self, t: float) -> Vec:
        """``∫ command dt`` from the first command to ``t`` (exact for the piecewise constant)."""
        if self.window is not None:
            start, (x, y, z), (u, v, w) = self.pinned
            span = t - start
            return x + u * span, y + v * span, z + w * span
        x, y, z = self.folded
        for start, end, value in self.segments:
            if t <= start:
                break
            span = min(t, end) - start
            x, y, z = x + value[0] * span, y + value[1] * span, z + value[2] * span
        return x, y, z

    def integral(self, t: float) -> FloatArray:
        """:meth:`integral_at` as a (3,) array."""
        return np.array(self.integral_at(t))


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

    def accept_input(self, input_name: str, t: float, value: Vec | FloatArray) -> None:
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
