"""The reaction-wheel array of :mod:`.effects.reaction_wheels` for a chunk of bodies.

The same drive law, hold and commit as the single-body effect, on rows: every body of a chunk
has its own wheel momenta, held torques and totals in the effect's state rows
(:func:`state_rows`: ``N`` wheels give ``6 N + 5`` rows), and may have its own axes, spin
inertia and limits (dispersed parameters). Layout of the rows, ``N`` each: momentum ``Hᵢ``,
held net torque ``uᵢ``, motor torque, friction torque, speed at the step's start, speed-limit
cut (0/1); then one each: any cut in the step, peak ``|Ω|`` [rad/s], time saturated [s],
motor work [J], friction loss [J].
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.dynamics.batch_rows import BatchChunk

__all__ = ['commit', 'hold', 'rotor', 'spin_inertia', 'start', 'state_rows', 'totals']

FloatArray = NDArray[np.float64]

#: Names of the per-body totals, in row order after the per-wheel blocks and the cut flag.
TOTALS = ('peak_speed', 'time_saturated', 'motor_work', 'friction_loss')


def state_rows(wheels: int) -> int:
    """Rows of per-body state for ``wheels`` wheels."""
    return 6 * wheels + 1 + len(TOTALS)


def _axes(effect: Any, parameters: Mapping[str, Any]) -> FloatArray:
    """Unit spin axes (3, N, n or 1)."""
    axes = np.asarray(parameters['axes'], dtype=np.float64)
    if axes.ndim == 2:  # shared (N, 3)
        axes = axes.T[:, :, None]
    norm = np.sqrt(np.einsum('iwn,iwn->wn', axes, axes))
    result: FloatArray = axes / norm
    return result


def _per_wheel(effect: Any, parameters: Mapping[str, Any], key: str) -> FloatArray:
    """A per-wheel parameter as (N, n) or (N, 1) rows (shared or dispersed)."""
    nominal = effect.params[key]
    value = np.asarray(parameters[key], dtype=np.float64)
    count = effect.wheel_count
    if isinstance(nominal, np.ndarray):
        return value[:, None] if value.ndim == 1 else value
    if value.ndim == 0:
        return np.full((count, 1), float(value))
    return np.broadcast_to(value[None, :], (count, value.shape[0]))


def spin_inertia(effect: Any, parameters: Mapping[str, Any], count: int) -> FloatArray:
    """``Σ Jₛᵢ âᵢ âᵢᵀ`` per body, (3, 3, n) or (3, 3, 1)."""
    axes = _axes(effect, parameters)
    inertia = _per_wheel(effect, parameters, 'spin_inertia')
    result: FloatArray = np.einsum('wn,iwn,jwn->ijn', inertia, axes, axes)
    return result


def _blocks(effect: Any, state: FloatArray) -> list[FloatArray]:
    """The six per-wheel blocks (N, n) of ``state``."""
    count = effect.wheel_count
    return [state[k * count:(k + 1) * count] for k in range(6)]


def _speeds(effect: Any, chunk: BatchChunk, omega: FloatArray) -> FloatArray:
    """Relative wheel speeds (N, n): ``Hᵢ/Jₛᵢ − âᵢ·ω``."""
    momentum = _blocks(effect, chunk.state)[0]
    result: FloatArray = momentum / _per_wheel(effect, chunk.parameters, 'spin_inertia') - \
        np.einsum('iwn,in->wn', _axes(effect, chunk.parameters), omega)
    return result


def start(effect: Any, omega: FloatArray, chunk: BatchChunk) -> None:
    """``Hᵢ = Jₛᵢ (Ωᵢ(0) + âᵢ·ω)``; every other row zero."""
    state = chunk.state
    state[:] = 0.0
    inertia = _per_wheel(effect, chunk.parameters, 'spin_inertia')
    initial = _per_wheel(effect, chunk.parameters, 'initial_speed')
    axes = _axes(effect, chunk.parameters)
    state[:effect.wheel_count] = inertia * (initial + np.einsum('iwn,in->wn', axes, omega))
    peak = len(TOTALS)
    state[-peak] = np.max(np.abs(_speeds(effect, chunk, omega)), axis=0)
    _sum_held(effect, chunk)


def _allocation(effect: Any, chunk: BatchChunk) -> FloatArray:
    """``A⁺`` per body (n or 1, N, 3), computed once per chunk."""
    allocation = chunk.workspace.get('allocation')
    if allocation is None:
        axes = _axes(effect, chunk.parameters)  # (3, N, n)
        allocation = np.asarray(np.linalg.pinv(axes.transpose(2, 0, 1)), dtype=np.float64)
        chunk.workspace['allocation'] = allocation
    return allocation


def _wanted(effect: Any, t: float, speeds: FloatArray, chunk: BatchChunk) -> FloatArray:
    """Motor torques asked (N, n) by the held command and the controllers."""
    held = effect.command.vector_at(t)
    values = np.array(held[1:])[:, None]
    if held[0] == 1.0:  # speed mode
        inertia = _per_wheel(effect, chunk.parameters, 'spin_inertia')
        wanted: FloatArray = inertia * effect.params['speed_gain'] * (values - speeds)
    else:
        wanted = np.broadcast_to(values, speeds.shape).copy()
    for controller in effect.controllers:
        torque = chunk.peers[controller.name].state[:3]  # (3, n)
        wanted -= np.einsum('nwi,in->wn', _allocation(effect, chunk), torque)
    return wanted


def hold(effect: Any, t: float, h: float, omega: FloatArray, chunk: BatchChunk) -> None:
    """The drive law of :func:`.effects.reaction_wheels.drive_torques` on every wheel of
    every body, held from ``t``."""
    parameters = chunk.parameters
    momentum, net, motor_row, friction_row, start_speed, cut_row = _blocks(effect, chunk.state)
    speeds = _speeds(effect, chunk, omega)
    limit = _per_wheel(effect, parameters, 'max_torque')
    motor = np.clip(_wanted(effect, t, speeds, chunk), -limit, limit)
    cut = (np.abs(speeds) >= _per_wheel(effect, parameters, 'max_speed')) & (motor * speeds > 0)
    motor[cut] = 0.0
    coulomb = _per_wheel(effect, parameters, 'coulomb_friction')
    inertia = _per_wheel(effect, parameters, 'spin_inertia')
    friction = np.copysign(coulomb, speeds) + _per_wheel(
        effect, parameters, 'viscous_friction') * speeds
    at_rest = speeds == 0.0
    friction = np.where(at_rest, np.clip(motor, -coulomb, coulomb), friction)
    end = speeds + (motor - friction) * h / inertia
    stick = ~at_rest & (end * speeds < 0.0) & (np.abs(motor) <= coulomb)
    friction = np.where(stick, motor + inertia * speeds / h, friction)
    motor_row[:], friction_row[:] = motor, friction
    net[:] = motor - friction
    start_speed[:] = speeds
    cut_row[:] = cut
    chunk.state[6 * effect.wheel_count] = np.any(cut, axis=0)
    effect.batch_hold_time = t
    _sum_held(effect, chunk)


def _sum_held(effect: Any, chunk: BatchChunk) -> None:
    """Each body's ``Σ Hᵢ âᵢ`` and ``Σ uᵢ âᵢ`` (3, n) into the chunk's work arrays."""
    momentum, net = _blocks(effect, chunk.state)[:2]
    axes = _axes(effect, chunk.parameters)
    np.einsum('iwn,wn->in', axes, momentum, out=chunk.scratch('held_momentum', 3))
    np.einsum('iwn,wn->in', axes, net, out=chunk.scratch('held_rate', 3))


def rotor(effect: Any, t: float, chunk: BatchChunk) -> tuple[FloatArray, FloatArray]:
    """``(h, ḣ)`` of every body (3, n), exact inside the held step."""
    rate = chunk.scratch('held_rate', 3)
    momentum = chunk.scratch('rotor_momentum', 3)
    np.multiply(rate, t - effect.batch_hold_time, out=momentum)
    momentum += chunk.scratch('held_momentum', 3)
    return momentum, rate


def commit(effect: Any, t: float, h: float, omega_end: FloatArray, chunk: BatchChunk) -> None:
    """``Hᵢ += uᵢ h`` for every body; its totals kept."""
    momentum, net, motor, friction, start_speed, _ = _blocks(effect, chunk.state)
    momentum += net * h
    speeds = _speeds(effect, chunk, omega_end)
    turned = 0.5 * h * (start_speed + speeds)
    state = chunk.state
    base = 6 * effect.wheel_count
    np.fmax(state[base + 1], np.max(np.abs(speeds), axis=0), out=state[base + 1])
    state[base + 2] += h * state[base]
    state[base + 3] += np.sum(motor * turned, axis=0)
    state[base + 4] += np.sum(friction * turned, axis=0)
    effect.batch_hold_time = t + h
    _sum_held(effect, chunk)


def totals(effect: Any, state: FloatArray) -> dict[str, FloatArray]:
    """Each body's totals (n,) by name (:data:`TOTALS`) from its state rows."""
    base = 6 * effect.wheel_count + 1
    return {name: state[base + k].copy() for k, name in enumerate(TOTALS)}


def momenta(effect: Any, parameters: Mapping[str, Any], state: FloatArray) -> FloatArray:
    """Each body's ``Σ Hᵢ âᵢ`` (3, n) from its state rows and parameters."""
    result: FloatArray = np.einsum('iwn,wn->in', _axes(effect, parameters),
                                   state[:effect.wheel_count])
    return result


def energies(effect: Any, parameters: Mapping[str, Any], state: FloatArray) -> FloatArray:
    """Each body's ``Σ Hᵢ²/(2 Jₛᵢ)`` (n,)."""
    momentum = state[:effect.wheel_count]
    result: FloatArray = np.sum(momentum ** 2 / (2.0 * _per_wheel(
        effect, parameters, 'spin_inertia')), axis=0)
    return result


def relative_momenta(effect: Any, parameters: Mapping[str, Any], state: FloatArray,
                     omega: FloatArray) -> FloatArray:
    """Each body's stored wheel momentum ``Σ Jₛᵢ Ωᵢ âᵢ`` (3, n) (what dumping removes)."""
    axes = _axes(effect, parameters)
    inertia = _per_wheel(effect, parameters, 'spin_inertia')
    speeds = state[:effect.wheel_count] / inertia - np.einsum('iwn,in->wn', axes, omega)
    result: FloatArray = np.einsum('iwn,wn->in', axes, inertia * speeds)
    return result
