"""reaction_wheels: an array of reaction wheels with torque and speed limits and friction.

Each wheel ``i`` spins about a body axis ``âᵢ`` (``axes``, normalised) with spin inertia
``Jₛᵢ``; its state is the absolute axial momentum ``Hᵢ = Jₛᵢ (Ωᵢ + âᵢ·ω)``, ``Ωᵢ`` the
speed relative to the body (what a tachometer reads). With ``J`` the whole spacecraft's
inertia, wheels locked (``body.inertia``), and ``J' = J − Σ Jₛᵢ âᵢ âᵢᵀ``:

    J' ω̇ + ω × (J' ω + Σ Hᵢ âᵢ) = M − Σ uᵢ âᵢ,        Ḣᵢ = uᵢ = τₘᵢ − τ_fᵢ

(Source: F. L. Markley and J. L. Crassidis, *Fundamentals of Spacecraft Attitude Determination and
Control*, 2014, sec. 3.3.5 (the reaction-wheel dynamics); P. C. Hughes, *Spacecraft Attitude
Dynamics*, 1986, sec. 3.4; the balanced wheels of Basilisk's reactionWheelStateEffector, whose
hub inertia likewise holds the wheels).

The drive: the motor torque ``τₘ`` is the commanded one clipped to ``±max_torque``; in speed
mode it is the speed servo ``Jₛ · speed_gain · (Ω_cmd − Ω)`` before the clip (a controller
commanding speeds needs nothing else; a steady friction leaves a speed error
``τ_f / (Jₛ · speed_gain)``). At ``|Ω| ≥ max_speed`` a motor torque that would speed the wheel
up further is cut to zero (counted once per episode as ``speed_limit``). Friction
``τ_f = coulomb_friction · sign(Ω) + viscous_friction · Ω`` opposes the relative speed; a
wheel whose friction would reverse it within the step stops at zero and sticks while
``|τₘ| ≤ coulomb_friction`` (Karnopp's stick-slip model in discrete time; Basilisk's Stribeck
term is left out). Motor torque, servo and friction are evaluated at the start of each
integration step and held over it (the drive electronics as a zero-order hold at the scene's
step), so ``Hᵢ`` is exactly linear inside a step and every integrator sees a rotor momentum
known in time; the scene's step must keep ``step · speed_gain ≤ 1`` and
``step · viscous_friction / Jₛ ≤ 1`` (the held servo and friction then never overshoot).

Commands: one per array, stamped, held until ``timeout`` (then the motors coast, counted as
``stale``) or the next command, with the lockstep contract of ``commanded_torque``:
``wheel_torque`` (one motor torque per wheel [N m], in ``names`` order) or ``wheel_speed``
(one speed per wheel [rad/s]). A command above the limits is clipped and counted
(``torque_limit``, ``speed_command_limit``). With ``commanded: false`` the array takes no
command (only a controller of the scene drives it, and a lockstep loop waits for none). An
``attitude_pd`` controller with ``actuator: reaction_wheels`` adds its body torque ``τ_c``,
allocated over the wheels with the minimum-norm pseudo-inverse: ``τₘ = −A⁺ τ_c``,
``A = [â₁ … â_N]`` (the body feels ``−A τₘ = τ_c`` when the wheels span the three axes;
:mod:`rigid_body_attitude.core.control.allocation`).

Energy: the total kinetic energy ``½ ωᵀ J' ω + Σ Hᵢ²/(2 Jₛᵢ)`` changes by the work of the
external torques plus the motors' work ``∫ τₘ Ω dt`` minus the friction loss ``∫ τ_f Ω dt``
(both kept, by the trapezoidal rule on ``Ω``). Assumptions and limitations: balanced wheels (no
jitter, no wheel mass offset), the wheels' transverse inertia in ``J``, no power limit, no
motor dynamics beyond the hold. In a batch every body has its own wheel state, and
``axes``, ``spin_inertia`` and the limits may be dispersed (axes are normalised per body: a
normal spread ``σ`` of the components tilts each axis by about ``σ`` rad).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from rigid_body_attitude.core.control.allocation import minimum_norm_allocation
from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, BodyProperties, boolean, CommandedEffect, Effect, FloatArray, HeldInput,
    nonnegative, Parameter, positive, Quat, real, register, REQUIRED, Vec)
from rigid_body_attitude.core.dynamics.effects.held import RotorState
from rigid_body_attitude.core.dynamics.effects.sampled import SampledTorque
from rigid_body_attitude.core.dynamics import wheel_batch
from rigid_body_attitude.core.errors import SceneError

#: Most wheels in one array.
MAX_WHEELS = 16
TORQUE_MODE, SPEED_MODE = 0.0, 1.0


def _axes(value: Any) -> FloatArray:
    """A list of 1 to 16 non-zero 3-vectors, each normalised."""
    if not isinstance(value, (list, tuple)) or not 1 <= len(value) <= MAX_WHEELS:
        raise TypeError(f'a list of 1 to {MAX_WHEELS} axes [x, y, z]')
    rows = []
    for axis in value:
        if not isinstance(axis, (list, tuple)) or len(axis) != 3:
            raise TypeError(f'a list of 1 to {MAX_WHEELS} axes [x, y, z]')
        row = np.array([real(item) for item in axis])
        scale = float(np.max(np.abs(row)))
        if not scale > 1e-12:
            raise ValueError('non-zero axes')
        row = row / scale
        rows.append(row / np.linalg.norm(row))
    return np.array(rows)


def _per_wheel(check: Any) -> Any:
    """A converter: one number for every wheel, or a list with one per wheel."""
    def convert(value: Any) -> float | FloatArray:
        if isinstance(value, (list, tuple, np.ndarray)):
            if not 1 <= len(value) <= MAX_WHEELS:
                raise TypeError('one number or a list with one number per wheel')
            return np.array([check(item) for item in value])
        result: float = check(value)
        return result
    return convert


def _names(value: Any) -> tuple[str, ...]:
    """A list of distinct wheel names (1 to 64 characters each), or empty (generated)."""
    if not isinstance(value, (list, tuple)) or len(value) > MAX_WHEELS or not all(
            isinstance(name, str) and 1 <= len(name) <= 64 for name in value):
        raise TypeError(f'a list of at most {MAX_WHEELS} names of 1 to 64 characters')
    if len(set(value)) != len(value):
        raise ValueError('distinct names')
    return tuple(value)


@register
class ReactionWheels(CommandedEffect, RotorState):
    """An array of reaction wheels: held motor torques, speed servo, limits, friction."""

    name = 'reaction_wheels'
    description = ('reaction-wheel array: torque or speed commands, torque and speed limits, '
                   'Coulomb and viscous friction; wheel momentum in the body dynamics')
    parameters = {
        'axes': Parameter(_axes, REQUIRED, 'spin axis of each wheel, body axes (normalised)'),
        'spin_inertia': Parameter(_per_wheel(positive), REQUIRED,
                                  'spin-axis inertia per wheel [kg m²]'),
        'max_torque': Parameter(_per_wheel(positive), REQUIRED, 'motor torque limit [N m]'),
        'max_speed': Parameter(_per_wheel(positive), REQUIRED,
                               'speed limit relative to the body [rad/s]'),
        'coulomb_friction': Parameter(_per_wheel(nonnegative), 0.0,
                                      'Coulomb friction torque [N m]'),
        'viscous_friction': Parameter(_per_wheel(nonnegative), 0.0,
                                      'viscous friction coefficient [N m s/rad]'),
        'speed_gain': Parameter(positive, 5.0, 'speed servo gain [1/s]'),
        'initial_speed': Parameter(_per_wheel(real), 0.0,
                                   'wheel speeds relative to the body at t = 0 [rad/s]'),
        'names': Parameter(_names, [], 'wheel names (default wheel_1, wheel_2, ...)'),
        'timeout': Parameter(positive, 0.5, 'seconds a wheel command is held [s]'),
        'commanded': Parameter(boolean, True, 'take wheel_torque and wheel_speed commands '
                                              '(false: only a controller of the scene)'),
    }
    inputs = {'wheel_torque': 'motor torque per wheel [N m] (JointState.effort)',
              'wheel_speed': 'speed per wheel relative to the body [rad/s] '
                             '(JointState.velocity)'}
    shared_parameters: ClassVar[frozenset[str]] = frozenset({'names', 'speed_gain',
                                                             'commanded'})

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Validate; broadcast the per-wheel parameters; no command, wheels at rest."""
        super().__init__(params, body)
        axes = self.params['axes']
        self.wheel_count = count = int(axes.shape[0])
        self.axes = [tuple(axis) for axis in axes.tolist()]
        wheel = {key: _broadcast(self.name, key, self.params[key], count) for key in (
            'spin_inertia', 'max_torque', 'max_speed', 'coulomb_friction', 'viscous_friction',
            'initial_speed')}
        self.wheel = wheel
        names = self.params['names'] or tuple(f'wheel_{i + 1}' for i in range(count))
        if len(names) != count:
            raise SceneError(f'Effect {self.name!r}: parameter \'names\' must be one name per '
                             f'wheel ({count}), got {len(names)}')
        self.names = tuple(names)
        self.allocation = minimum_norm_allocation(axes)  # (N, 3): τₘ = −A⁺ τ_c
        self.command = HeldInput(self, self.params['timeout'], size=count + 1)
        self.controllers: list[SampledTorque] = []
        self.reset()

    @property
    def input_names(self) -> frozenset[str]:
        """``wheel_torque`` and ``wheel_speed`` unless ``commanded`` is false."""
        return frozenset(self.inputs) if self.params['commanded'] else frozenset()

    def input_size(self, input_name: str) -> int:
        """One number per wheel."""
        return self.wheel_count

    def accept_input(self, input_name: str, t: float, value: Vec | FloatArray) -> None:
        """Hold a torque or speed command from ``t``, clipped to the limits (counted)."""
        value = np.asarray(value, dtype=np.float64)
        limit = self.wheel['max_torque' if input_name == 'wheel_torque' else 'max_speed']
        clipped = np.clip(value, -np.asarray(limit), limit)
        if np.any(clipped != value):
            self.count('torque_limit' if input_name == 'wheel_torque' else
                       'speed_command_limit')
        mode = TORQUE_MODE if input_name == 'wheel_torque' else SPEED_MODE
        self.command.set(t, np.concatenate([[mode], clipped]))

    def bind(self, effects: Sequence[Effect]) -> None:
        """Take the body torque of every controller whose ``actuator`` is this array."""
        self.controllers = [e for e in effects if isinstance(e, SampledTorque)
                            and e.actuator == self.name]

    def check_step(self, step: float) -> None:
        """The held servo and viscous friction must not overshoot within a step."""
        gain = self.params['speed_gain']
        if step * gain > 1.0:
            raise SceneError(f'Effect {self.name!r}: parameter \'speed_gain\' {gain!r} 1/s '
                             f'times the step {step!r} s must be at most 1 (the held servo '
                             f'overshoots); lower the gain or the step')
        wheel = self.wheel
        ratio = max(step * c / j for c, j in zip(wheel['viscous_friction'],
                                                 wheel['spin_inertia']))
        if ratio > 1.0:
            raise SceneError(f'Effect {self.name!r}: parameter \'viscous_friction\' times the '
                             f'step over spin_inertia is {ratio:.3g}, above 1 (the held '
                             f'friction overshoots); lower it or the step')

    def reset(self) -> None:
        """No command held; wheels at their initial speeds once :meth:`start` runs."""
        super().reset()
        count = self.wheel_count
        self.momentum = [0.0] * count  # Hᵢ [N m s]
        self.net = [0.0] * count  # uᵢ held over the step [N m]
        self.motor = [0.0] * count
        self.friction = [0.0] * count
        self.cutting = [False] * count
        self.speeds_start = [0.0] * count
        self.hold_time = 0.0
        self.held_momentum: Vec = (0.0, 0.0, 0.0)
        self.held_rate: Vec = (0.0, 0.0, 0.0)
        self.omega: Vec = (0.0, 0.0, 0.0)
        self.peak_speed = self.time_saturated = self.motor_work = self.friction_loss = 0.0
        #: Per wheel: time cut at the speed limit [s], episodes of it, time asked beyond
        #: ``max_torque`` [s], angle relative to the body [rad] in [−π, π] (trapezoidal).
        self.speed_limited_time = [0.0] * count
        self.speed_limit_episodes = [0] * count
        self.torque_limited_time = [0.0] * count
        self.angles = [0.0] * count
        self.torque_limited = [False] * count
        self.cut_this_step = False
        self.batch_hold_time = 0.0

    def spin_inertia_body(self) -> FloatArray:
        """``Σ Jₛᵢ âᵢ âᵢᵀ`` [kg m²]."""
        axes = self.params['axes']
        result: FloatArray = np.einsum('i,ij,ik->jk', np.array(self.wheel['spin_inertia']),
                                       axes, axes)
        return result

    def start(self, omega_body: Vec) -> None:
        """``Hᵢ = Jₛᵢ (Ωᵢ(0) + âᵢ·ω)``."""
        self.omega = omega_body
        self.momentum = [j * (speed + _dot(axis, omega_body)) for j, speed, axis in zip(
            self.wheel['spin_inertia'], self.wheel['initial_speed'], self.axes)]
        self.net = [0.0] * self.wheel_count
        self._sum_held(0.0)
        self.peak_speed = max(abs(speed) for speed in self.speeds())

    def speeds(self, omega_body: Vec | None = None) -> list[float]:
        """Wheel speeds relative to the body [rad/s] at the propagated time (or for the body
        rate ``omega_body`` with the current momenta)."""
        omega = self.omega if omega_body is None else omega_body
        return [h / j - _dot(axis, omega) for h, j, axis in zip(
            self.momentum, self.wheel['spin_inertia'], self.axes)]

    def _command_torques(self, t: float, speeds: list[float]) -> list[float]:
        """Motor torques asked by the held command and the controllers, before the limits."""
        held = self.command.vector_at(t)
        if held[0] == SPEED_MODE:
            gain = self.params['speed_gain']
            wanted = [j * gain * (target - speed) for j, target, speed in zip(
                self.wheel['spin_inertia'], held[1:], speeds)]
        else:
            wanted = list(held[1:])
        for controller in self.controllers:
            tx, ty, tz = controller.held
            wanted = [w - (a * tx + b * ty + c * tz)
                      for w, (a, b, c) in zip(wanted, self.allocation)]
        return wanted

    def hold(self, t: float, h: float, q: Quat, omega: Vec) -> None:
        """Motor and friction torques from the wheel speeds and the command at ``t``."""
        self.omega = omega
        speeds = self.speeds()
        wanted = self._command_torques(t, speeds)
        wheel = self.wheel
        cut_any = False
        for i, (speed, command) in enumerate(zip(speeds, wanted)):
            motor, friction, cut = drive_torques(
                speed, command, wheel['spin_inertia'][i], wheel['max_torque'][i],
                wheel['max_speed'][i], wheel['coulomb_friction'][i],
                wheel['viscous_friction'][i], h)
            if cut and not self.cutting[i]:
                self.count('speed_limit')
                self.speed_limit_episodes[i] += 1
            self.cutting[i] = cut
            self.torque_limited[i] = abs(command) > wheel['max_torque'][i]
            cut_any = cut_any or cut
            self.motor[i], self.friction[i] = motor, friction
            self.net[i] = motor - friction
        self.cut_this_step = cut_any
        self.speeds_start = speeds
        self._sum_held(t)

    def _sum_held(self, t: float) -> None:
        """``h = Σ Hᵢ âᵢ`` and ``ḣ = Σ uᵢ âᵢ`` held from ``t`` on."""
        hx = hy = hz = rx = ry = rz = 0.0
        for (a, b, c), momentum, net in zip(self.axes, self.momentum, self.net):
            hx, hy, hz = hx + momentum * a, hy + momentum * b, hz + momentum * c
            rx, ry, rz = rx + net * a, ry + net * b, rz + net * c
        self.hold_time = t
        self.held_momentum, self.held_rate = (hx, hy, hz), (rx, ry, rz)

    def rotor(self, t: float) -> tuple[Vec, Vec]:
        """``(Σ Hᵢ(t) âᵢ, Σ uᵢ âᵢ)``, exact inside the held step."""
        (hx, hy, hz), rate = self.held_momentum, self.held_rate
        span = t - self.hold_time
        return (hx + rate[0] * span, hy + rate[1] * span, hz + rate[2] * span), rate

    def commit(self, t: float, h: float, omega_start: Vec, omega_end: Vec) -> float:
        """``Hᵢ += uᵢ h``; motor work, friction loss, peak speed, time saturated."""
        energy = 0.0
        for i, (j, net) in enumerate(zip(self.wheel['spin_inertia'], self.net)):
            old = self.momentum[i]
            new = self.momentum[i] = old + net * h
            energy += (new * new - old * old) / (2.0 * j)
        self.omega = omega_end
        speeds = self.speeds()
        for i, (start, end, motor, friction) in enumerate(zip(
                self.speeds_start, speeds, self.motor, self.friction)):
            turned = 0.5 * h * (start + end)  # ∫ Ω dt [rad]
            self.motor_work += motor * turned
            self.friction_loss += friction * turned
            self.peak_speed = max(self.peak_speed, abs(end))
            _turn(self.angles, i, turned)
        _tally_limits(self, h)
        self._sum_held(t + h)
        return energy

    def kinetic_energy(self) -> float:
        """``Σ Hᵢ²/(2 Jₛᵢ)`` [J]."""
        return sum(h * h / (2.0 * j) for h, j in zip(self.momentum, self.wheel['spin_inertia']))

    def stored_momentum(self) -> Vec:
        """``Σ Jₛᵢ Ωᵢ âᵢ`` [N m s] at the propagated time."""
        x = y = z = 0.0
        for (a, b, c), j, speed in zip(self.axes, self.wheel['spin_inertia'], self.speeds()):
            x, y, z = x + j * speed * a, y + j * speed * b, z + j * speed * c
        return x, y, z

    def batch_rotor(self, t: float, chunk: BatchChunk) -> tuple[FloatArray, Any]:
        """Each body's ``(h, ḣ)`` from its held rows."""
        return wheel_batch.rotor(self, t, chunk)

    def batch_spin_inertia(self, parameters: Mapping[str, Any], count: int) -> FloatArray:
        """``Σ Jₛᵢ âᵢ âᵢᵀ`` of every body (3, 3, n or 1)."""
        return wheel_batch.spin_inertia(self, parameters, count)

    def batch_state_rows(self) -> int:
        """Momenta, held torques, start speeds, cut flags and the four totals."""
        return wheel_batch.state_rows(self.wheel_count)

    def batch_start(self, omega: FloatArray, chunk: BatchChunk) -> None:
        """Every body's wheels at their initial speeds."""
        wheel_batch.start(self, omega, chunk)

    def batch_hold(self, t: float, h: float, q: FloatArray, omega: FloatArray,
                   chunk: BatchChunk) -> None:
        """Every body's drive torques for the step."""
        wheel_batch.hold(self, t, h, omega, chunk)

    def batch_commit(self, t: float, h: float, omega_start: FloatArray,
                     omega_end: FloatArray, chunk: BatchChunk) -> None:
        """Every body's momenta advanced; its totals kept."""
        wheel_batch.commit(self, t, h, omega_end, chunk)


def _turn(angles: list[float], i: int, turned: float) -> None:
    """Wheel ``i``'s angle [rad] turned by ``turned``, kept in [−π, π]."""
    angle = angles[i] + turned
    angles[i] = angle if -math.pi <= angle <= math.pi else math.remainder(angle, math.tau)


def _tally_limits(wheels: ReactionWheels, h: float) -> None:
    """A step of ``h`` [s] held: the time at the speed limit (any wheel, and each) and at
    the torque limit (each)."""
    if wheels.cut_this_step:
        wheels.time_saturated += h
        for i, cut in enumerate(wheels.cutting):
            if cut:
                wheels.speed_limited_time[i] += h
    for i, limited in enumerate(wheels.torque_limited):
        if limited:
            wheels.torque_limited_time[i] += h


def _dot(axis: tuple[float, ...], vector: Vec) -> float:
    return axis[0] * vector[0] + axis[1] * vector[1] + axis[2] * vector[2]


def _broadcast(effect: str, key: str, value: float | FloatArray, count: int) -> list[float]:
    """A per-wheel parameter as ``count`` floats; SceneError naming ``key`` otherwise."""
    if isinstance(value, np.ndarray):
        if value.shape != (count,):
            raise SceneError(f'Effect {effect!r}: parameter {key!r} must be one number or one '
                             f'per wheel ({count}), got {len(value)}')
        result: list[float] = value.tolist()
        return result
    return [float(value)] * count


def drive_torques(speed: float, command: float, spin_inertia: float, max_torque: float,
                  max_speed: float, coulomb: float, viscous: float,
                  h: float) -> tuple[float, float, bool]:
    """``(τₘ, τ_f, cut)`` of one wheel at relative ``speed`` for a step of ``h``: the motor
    torque ``command`` clipped and cut at the speed limit, and the friction (module
    docstring); ``cut`` whether the speed limit cut a torque."""
    motor = max(-max_torque, min(max_torque, command))
    cut = abs(speed) >= max_speed and motor * speed > 0.0
    if cut:
        motor = 0.0
    if speed == 0.0:
        friction = max(-coulomb, min(coulomb, motor))
        return motor, friction, cut
    friction = math.copysign(coulomb, speed) + viscous * speed
    end = speed + (motor - friction) * h / spin_inertia
    if end * speed < 0.0 and abs(motor) <= coulomb:
        friction = motor + spin_inertia * speed / h  # sticks at zero by the step's end
    return motor, friction, cut
