"""Each run's dispersed parameters, drawn from its own stream (:class:`.RunStreams`).

A run's draws depend only on the campaign's seed and the run's index, never on the other runs
of its chunk, so any chunking on any number of workers gives the same runs. Each kind of draw
has its own stream category, so adding one dispersion to a spec leaves the others' draws as
they were.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.dynamics.dispersions import (
    cone_quaternions, dispersed_inertia, perturbed_tensors, RunStreams, uniform_quaternions)
from rigid_body_attitude.tools.campaign.spec import CampaignSpec, Spread

__all__ = ['RunParameters', 'sample_runs']

FloatArray = NDArray[np.float64]

_ATTITUDE, _MOMENTS, _AXES, _TENSOR, _RATES = 0, 1, 2, 3, 4
_EFFECTS = 16
_COMMANDS = 2048


@dataclass
class RunParameters:
    """The parameters of ``n`` runs.

    Attributes:
        runs: campaign indices (n,); seeds: each run's stream seed (n,).
        attitude: initial attitudes (n, 4); omega_body: initial rates (n, 3) [rad/s].
        inertia: tensors (n, 3, 3) [kg m²], or ``None`` for the scene's.
        effects: dispersed effect parameters, ``effects[effect][parameter]`` (n,) or (n, 3).
        commands: commanded torques per command (k, n, 3) [N m, body].
    """

    runs: NDArray[np.int64]
    seeds: NDArray[np.uint64]
    attitude: FloatArray
    omega_body: FloatArray
    inertia: FloatArray | None
    effects: dict[str, dict[str, FloatArray]] = field(default_factory=dict)
    commands: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 3)))


def _spread(streams: RunStreams, category: int, spread: Spread, nominal: ArrayLike,
            size: int) -> FloatArray:
    """Draws (n, size) of ``spread`` about ``nominal``."""
    base = np.broadcast_to(np.asarray(nominal, dtype=np.float64).ravel(), (size,))
    if spread.kind == 'uniform':
        u = streams.uniform(category, size)
        result: FloatArray = spread.low + u * (spread.high - spread.low)
        return result
    normals = streams.normal(category, size)
    scale = spread.sigma * (np.abs(base) if spread.kind == 'relative_sigma' else 1.0)
    return base + normals * scale


def _inertia(spec: CampaignSpec, streams: RunStreams) -> FloatArray | None:
    dispersion = spec.inertia
    if dispersion is None:
        return None
    inertia = spec.scene.inertia
    if dispersion.tensor_sigma > 0.0:
        return perturbed_tensors(inertia.tensor, dispersion.tensor_sigma,
                                 streams.normal(_TENSOR, 6))
    n = streams.runs.shape[0]
    if dispersion.axes == 'uniform':
        rotations = uniform_quaternions(streams.uniform(_AXES, 3))
    elif dispersion.axes == 'cone':
        rotations = cone_quaternions([1.0, 0.0, 0.0, 0.0], dispersion.axes_cone,
                                     streams.uniform(_AXES, 3))
    else:
        rotations = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    return dispersed_inertia(inertia.principal_moments, inertia.principal_axes,
                             dispersion.second_moments_sigma, streams.normal(_MOMENTS, 3),
                             rotations)


def _attitude(spec: CampaignSpec, streams: RunStreams) -> FloatArray:
    nominal = spec.scene.initial_attitude
    if spec.attitude == 'uniform':
        return uniform_quaternions(streams.uniform(_ATTITUDE, 3))
    if spec.attitude == 'cone':
        return cone_quaternions(nominal, spec.attitude_cone, streams.uniform(_ATTITUDE, 3))
    return np.tile(nominal, (streams.runs.shape[0], 1))


def _effects(spec: CampaignSpec, streams: RunStreams) -> dict[str, dict[str, FloatArray]]:
    nominal = {effect.name: effect.params for effect in spec.scene.build_effects()}
    result: dict[str, dict[str, FloatArray]] = {}
    category = _EFFECTS
    for name in sorted(spec.effects):
        for parameter in sorted(spec.effects[name]):
            value = nominal[name][parameter]
            size = int(np.size(value))
            draws = _spread(streams, category, spec.effects[name][parameter], value, size)
            shaped = draws.reshape((draws.shape[0],) + np.shape(value))
            result.setdefault(name, {})[parameter] = shaped
            category += 1
    return result


def _commands(spec: CampaignSpec, streams: RunStreams) -> FloatArray:
    n = streams.runs.shape[0]
    commands = np.zeros((len(spec.commands), n, 3))
    for index, (_, torque) in enumerate(spec.commands):
        commands[index] = torque
        if spec.command_dispersion is not None:
            sigma = spec.command_dispersion.sigma
            commands[index] += streams.normal(_COMMANDS + index, 3) * sigma
    return commands


def sample_runs(spec: CampaignSpec, runs: ArrayLike) -> RunParameters:
    """The parameters of the campaign's ``runs`` (indices), drawn from their own streams."""
    indices = np.asarray(runs, dtype=np.int64)
    streams = RunStreams(spec.seed, indices)
    omega = np.tile(spec.scene.initial_omega_body, (indices.shape[0], 1))
    if spec.omega_body is not None:
        omega = _spread(streams, _RATES, spec.omega_body, spec.scene.initial_omega_body, 3)
    effects = _effects(spec, streams)
    return RunParameters(runs=indices, seeds=streams.seeds(), attitude=_attitude(spec, streams),
                         omega_body=omega, inertia=_inertia(spec, streams), effects=effects,
                         commands=_commands(spec, streams))
