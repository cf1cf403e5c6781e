"""Dynamics cases, built from scenes and their effects the way the propagator builds them.

Each case is a scene (:func:`rigid_body_attitude.core.dynamics.scene.scene_from_mapping`); a
:class:`~rigid_body_attitude.core.propagator.DynamicsPropagator` built from it supplies the
body model (inertia, the effects' torques and rotors) that every method integrates, and the
DOP853 references and scipy's DOP853 evaluate the same model (:func:`model_rhs`). No torque
or Euler right-hand side is written here. Methods run as ``integrator.integrate`` over the
whole run (family ``dynamics``); ``stepped`` rows advance the propagator itself at a fixed
rate (``DynamicsPropagator.advance_to``, diagnostics included), as the node does.

``torque_free``
    Hairer–Vilmart body (Hairer & Vilmart, J. Phys. A 39, 2006), T = 10 s; exact reference;
    invariant: world angular momentum drift.
``near_separatrix``
    J = (1, 2, 3), ω₀ = (1e−4, 1, 0), T = 30 s (several flips); exact reference.
``heavy_top``
    fast symmetric top on a pivot, J = diag(0.05, 0.05, 0.02) kg m², m g l = 0.981 N m, spin
    25 rad/s, T = 10 s; ``gravity_about_pivot``; invariant: total energy drift.
``gravity_gradient``
    the Hairer–Vilmart (triaxial) body under ``gravity_gradient`` on a circular orbit of mean
    motion 1 rad/s (3n² = 3/s², a torque comparable with the body's own dynamics), T = 10 s.
``commanded_torque``
    the triaxial body under ``commanded_torque`` with a new body torque commanded every
    0.1 s (zero-order hold, as a controller on the node's ``torque`` input), T = 10 s.

References for the torque cases: DOP853 at rtol 1e−13, resolution estimated from a run at
1e−12 (:func:`dop853_reference`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.euler import RigidBodyModel
from rigid_body_attitude.core.dynamics.effects.base import CommandedEffect
from rigid_body_attitude.core.dynamics.effects.gravity_about_pivot import GravityAboutPivot
from rigid_body_attitude.core.dynamics.integrators import TorqueFreeMotion, dynamics_integrator
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import Scene, scene_from_mapping
from rigid_body_attitude.tools.study.runner import Job, Outcome

__all__ = ['DynamicsCase', 'dynamics_jobs', 'model_rhs', 'DYNAMICS_CASES']

FloatArray = NDArray[np.float64]
Evaluate = Callable[[FloatArray, FloatArray], tuple[float, float]]

FIXED_STEP_METHODS = ('rk4', 'rkmk4', 'strang', 'yoshida4', 'casimir6', 'casimir8')
#: RKN splittings need the exact free flow (elliptic functions for a triaxial body); torque-free
#: they are the exact step, so they only appear in torque cases.
RKN_METHODS = ('rkn4', 'rkn6')
#: Exact solution: a few ulps of ψ ≈ 2T t/G ≈ 1e−14 rad, ×100.
EXACT_FLOOR = 2e-12
#: Rate [Hz] at which the ``stepped`` rows advance the propagator.
STEPPED_RATE = 100.0
HEAVY_TOP_MOMENTS = (0.05, 0.05, 0.02)


def body_scene(name: str, moments: Sequence[float], attitude: Sequence[float],
               omega_body: Sequence[float],
               effects: Sequence[Mapping[str, Any]] = ()) -> Scene:
    """A dynamics scene of a body with principal ``moments`` [kg m²] and ``effects``."""
    return scene_from_mapping({
        'name': name, 'rate_source': 'dynamics', 'integrator': 'rk4', 'step': 0.01,
        'body': {'mass': 1.0, 'inertia': {'moments': [float(j) for j in moments]}},
        'initial_state': {'attitude': [float(x) for x in attitude],
                          'omega_body': [float(w) for w in omega_body]},
        'effects': [dict(effect) for effect in effects]})


def model_rhs(model: RigidBodyModel) -> Callable[[float, FloatArray], FloatArray]:
    """``d(q, ω)/dt`` for scipy: Poisson's equation and the model's Euler equations."""
    def rhs(t: float, y: FloatArray) -> FloatArray:
        q, w = y[:4], y[4:]
        return np.concatenate([0.5 * quat.multiply(q, np.concatenate([[0.0], w])),
                               model.omega_dot(t, q, w)])
    return rhs


#: A command schedule: (stamp [s], body torque [N m]) pairs, each held to the next stamp.
Schedule = Sequence[tuple[float, tuple[float, float, float]]]


@dataclass
class DynamicsCase:
    """A dynamics case: its scene, run length, sweeps and what it measures.

    Attributes:
        name: case name.
        scene: the scene (its integrator and step are replaced per run).
        duration: simulated time [s].
        counts: step counts per fixed-step method.
        tolerances: dopri45 rtols (atol = 1e−3 rtol).
        scipy_tolerances: rtols of scipy's DOP853 as a competitor (empty: none).
        invariant: what the drift column measures.
        schedule: commands on the ``torque`` input, applied through the propagator.
        exact: the closed form is the reference (torque-free) and ``exact`` a method.
        stepped: methods also run through the propagator at :data:`STEPPED_RATE`.
    """

    name: str
    scene: Scene
    duration: float
    counts: dict[str, tuple[int, ...]]
    tolerances: tuple[float, ...]
    scipy_tolerances: tuple[float, ...] = ()
    invariant: str = ''
    schedule: Schedule = field(default_factory=tuple)
    exact: bool = False
    stepped: tuple[str, ...] = ()

    def propagator(self, integrator: str = 'rk4') -> DynamicsPropagator:
        """A propagator of the scene (its model is what every method integrates)."""
        return DynamicsPropagator(self.scene.with_overrides(integrator=integrator))

    def segments(self) -> list[tuple[float, float, tuple[float, float, float] | None]]:
        """``(start, end, command)`` spans of the run; one span without command if none."""
        if not self.schedule:
            return [(0.0, self.duration, None)]
        stamps = [t for t, _ in self.schedule] + [self.duration]
        return [(t, end, value) for (t, value), end in zip(self.schedule, stamps[1:])]


def _apply(propagator: DynamicsPropagator, start: float, end: float,
           command: tuple[float, float, float] | None) -> None:
    """Command ``command`` at ``start`` and pin every commanded effect to the command in
    force inside ``(start, end)``, as the propagator does per step: stages of methods with
    negative substeps (yoshida4, casimir6) then never see the previous command."""
    if command is None:
        return
    propagator.command('torque', start, command)
    for effect in propagator.effects:
        if isinstance(effect, CommandedEffect):
            effect.begin_step(start, end)


def dop853_reference(case: DynamicsCase, rtol: float) -> FloatArray:
    """DOP853 on the case's model, restarted at every command: the final ``(q, ω)`` (7,)."""
    propagator = case.propagator()
    y = np.concatenate([propagator.state.attitude, propagator.state.omega_body])
    rhs = model_rhs(propagator.model)
    for start, end, command in case.segments():
        _apply(propagator, start, end, command)
        y = solve_ivp(rhs, (start, end), y, method='DOP853', rtol=rtol,
                      atol=1e-2 * rtol).y[:, -1]
    return np.concatenate([quat.normalize(y[:4]), y[4:]])


def reference_state(case: DynamicsCase) -> tuple[FloatArray, FloatArray, float]:
    """The reference ``q(T)``, ``ω(T)`` and its resolution floor [rad]."""
    propagator = case.propagator()
    if case.exact:
        motion = TorqueFreeMotion(case.scene.inertia.tensor, propagator.state.attitude,
                                  omega_body=propagator.state.omega_body)
        q, w = motion.state(case.duration)
        return q, w, EXACT_FLOOR
    reference = dop853_reference(case, 1e-13)
    looser = dop853_reference(case, 1e-12)
    floor = 10.0 * max(float(quat.attitude_error(reference[:4], looser[:4])), 1e-16)
    return reference[:4], reference[4:], floor


def _run_integrator(case: DynamicsCase, propagator: DynamicsPropagator, name: str,
                    steps: int, options: Mapping[str, float]) -> tuple[Any, ...]:
    """``(q, ω, steps taken, note)`` of one run of ``name`` on the propagator's model."""
    integrator = dynamics_integrator(name, **options)
    propagator.reset()
    q, w = propagator.state.attitude, propagator.state.omega_body
    count = 0
    for start, end, command in case.segments():
        _apply(propagator, start, end, command)
        if name == 'dopri45':
            q, w = integrator.step(q, w, start, end - start, propagator.model)
        else:
            n = int(round(steps * (end - start) / case.duration))
            q, w = integrator.integrate(q, w, start, (end - start) / n, n, propagator.model)
            count += n
    if name != 'dopri45':
        return q, w, count, ''
    note = (f'rtol={integrator.rtol:.0e}, {integrator.evaluations} evaluations, '
            f'{integrator.steps_rejected} rejected')
    return q, w, integrator.steps_taken, note


def _integrator_job(case: DynamicsCase, name: str, steps: int, evaluate: Evaluate,
                    options: Mapping[str, float] | None = None) -> Job:
    """One run of a dynamics integrator over the whole case."""
    propagator = case.propagator()

    def measure() -> Outcome:
        q, w, count, note = _run_integrator(case, propagator, name, steps, options or {})
        if name == 'exact' and case.exact:
            note = 'the reference itself (closed form)'
        error, drift = evaluate(q, w)
        return Outcome(error, drift, count, note)
    step = math.nan if name == 'dopri45' else case.duration / steps
    return Job(case.name, name, 'dynamics', step, case.duration, measure, case.invariant)


def _stepped_job(case: DynamicsCase, name: str, evaluate: Evaluate) -> Job:
    """The propagator stepped at :data:`STEPPED_RATE` (``advance_to``), as the node runs."""
    step = 1.0 / STEPPED_RATE
    propagator = DynamicsPropagator(case.scene.with_overrides(integrator=name, step=step))

    def measure() -> Outcome:
        propagator.reset()
        steps = 0
        for start, end, command in case.segments():
            _apply(propagator, start, end, command)
            steps += propagator.advance_to(end)
        error, drift = evaluate(propagator.state.attitude, propagator.state.omega_body)
        return Outcome(error, drift, steps, f'DynamicsPropagator.advance_to at '
                       f'{STEPPED_RATE:.0f} Hz')
    return Job(case.name, f'{name} (propagator, {STEPPED_RATE:.0f} Hz)', 'stepped', step,
               case.duration, measure, case.invariant)


def _scipy_job(case: DynamicsCase, rtol: float, evaluate: Evaluate) -> Job:
    """scipy's DOP853 at ``rtol`` on the same model (the competitor)."""
    def measure() -> Outcome:
        propagator = case.propagator()
        y = np.concatenate([propagator.state.attitude, propagator.state.omega_body])
        rhs = model_rhs(propagator.model)
        steps = evaluations = 0
        for start, end, command in case.segments():
            _apply(propagator, start, end, command)
            result = solve_ivp(rhs, (start, end), y, method='DOP853', rtol=rtol,
                               atol=1e-3 * rtol)
            y, steps, evaluations = result.y[:, -1], steps + len(result.t) - 1, (
                evaluations + result.nfev)
        error, drift = evaluate(quat.normalize(y[:4]), y[4:])
        return Outcome(error, drift, steps, f'rtol={rtol:.0e}, {evaluations} f-evals')
    return Job(case.name, 'scipy DOP853', 'scipy', math.nan, case.duration, measure,
               case.invariant)


def _evaluator(case: DynamicsCase, reference_q: FloatArray,
               reference_w: FloatArray) -> Evaluate:
    """Attitude error against the reference and the case's invariant."""
    propagator = case.propagator()
    tensor = case.scene.inertia.tensor
    pivot = [e for e in propagator.effects if isinstance(e, GravityAboutPivot)]

    def energy(q: FloatArray, w: FloatArray) -> float:
        potential = sum(effect.potential_energy(q) for effect in pivot)
        return float(0.5 * w @ tensor @ w) + potential

    start_q, start_w = propagator.state.attitude, propagator.state.omega_body
    world = quat.rotate(start_q, tensor @ start_w)
    expected_energy = energy(reference_q, reference_w) if not case.exact else energy(
        start_q, start_w)

    def evaluate(q: FloatArray, w: FloatArray) -> tuple[float, float]:
        if case.exact:
            drift = float(np.linalg.norm(quat.rotate(q, tensor @ w) - world)
                          / np.linalg.norm(world))
        else:
            drift = abs(energy(q, w) / expected_energy - 1.0)
        return float(quat.attitude_error(q, reference_q)), drift
    return evaluate


def dynamics_jobs(case: DynamicsCase) -> list[Job]:
    """Every method's sweep on ``case`` (and the stepped and scipy rows it has)."""
    reference_q, reference_w, floor = reference_state(case)
    evaluate = _evaluator(case, reference_q, reference_w)
    jobs = [_integrator_job(case, name, steps, evaluate)
            for name, counts in case.counts.items() for steps in counts]
    jobs += [_integrator_job(case, 'dopri45', 1, evaluate, {'rtol': rtol, 'atol': 1e-3 * rtol})
             for rtol in case.tolerances]
    if case.exact:
        jobs.append(_integrator_job(case, 'exact', 1, evaluate))
    jobs += [_stepped_job(case, name, evaluate) for name in case.stepped]
    jobs += [_scipy_job(case, rtol, evaluate) for rtol in case.scipy_tolerances]
    for job in jobs:
        job.floor = floor
    return jobs


HAIRER_VILMART = (0.6, 0.8, 1.0)
HAIRER_VILMART_OMEGA = (1.8 / 0.6, 0.4 / 0.8, -0.9 / 1.0)


def _sweeps(quick: bool, fixed: Sequence[int], rkn: Sequence[int] = (),
            rkn_methods: Sequence[str] = RKN_METHODS,
            special: Mapping[str, Sequence[int]] | None = None) -> dict[str, tuple[int, ...]]:
    """Step counts per method (two per method with ``quick``)."""
    counts = {name: tuple(fixed) for name in FIXED_STEP_METHODS}
    counts.update({name: tuple(rkn) for name in rkn_methods if rkn})
    counts.update({name: tuple(values) for name, values in (special or {}).items()})
    if quick:
        counts = {name: values[:2] for name, values in counts.items()}
    return counts


def torque_free_case(quick: bool) -> DynamicsCase:
    """The Hairer–Vilmart body, torque-free."""
    scene = body_scene('torque_free', HAIRER_VILMART, (1.0, 0.0, 0.0, 0.0),
                       HAIRER_VILMART_OMEGA)
    counts = _sweeps(quick, (100, 400) if quick else (50, 100, 200, 400, 800, 1600), special={
        'casimir6': (25, 50, 100, 200), 'casimir8': (10, 15, 20, 30, 50)})
    return DynamicsCase('torque_free', scene, 10.0, counts,
                        (1e-8,) if quick else (1e-6, 1e-8, 1e-10, 1e-12),
                        (1e-8,) if quick else (1e-7, 1e-9, 1e-11),
                        'world momentum drift (rel.)', exact=True,
                        stepped=('exact', 'casimir8', 'rk4'))


def near_separatrix_case(quick: bool) -> DynamicsCase:
    """J = (1, 2, 3) next to the intermediate axis: several flips."""
    scene = body_scene('near_separatrix', (1.0, 2.0, 3.0), (1.0, 0.0, 0.0, 0.0),
                       (1e-4, 1.0, 0.0))
    counts = (200, 800) if quick else (100, 200, 400, 800, 1600, 3200)
    return DynamicsCase('near_separatrix', scene, 10.0 if quick else 30.0,
                        _sweeps(quick, counts), (1e-8,) if quick else (1e-6, 1e-8, 1e-10, 1e-12),
                        (), 'world momentum drift (rel.)', exact=True)


def heavy_top_case(quick: bool) -> DynamicsCase:
    """The fast symmetric heavy top (``gravity_about_pivot``)."""
    scene = body_scene('heavy_top', HEAVY_TOP_MOMENTS, quat.exp([0.3, 0.0, 0.0]).tolist(),
                       (0.0, 0.5, 25.0),
                       [{'gravity_about_pivot': {'centre_of_mass': [0.0, 0.0, 0.1],
                                                 'gravity': [0.0, 0.0, -9.81]}}])
    counts = _sweeps(quick, (), special={
        'rk4': (1000, 2000, 4000), 'rkmk4': (1000, 2000, 4000),
        'strang': (1000, 4000), 'yoshida4': (500, 1000, 2000),
        'casimir6': (100, 200, 400, 800), 'casimir8': (60, 80, 100, 130, 160),
        'rkn4': (100, 200, 400, 800), 'rkn6': (100, 150, 200, 250, 300)})
    return DynamicsCase('heavy_top', scene, 2.0 if quick else 10.0, counts,
                        (1e-8, 1e-10) if quick else (1e-6, 1e-8, 1e-10),
                        (1e-8, 1e-10) if quick else (1e-8, 1e-9, 1e-10, 1e-11),
                        'energy drift (rel.)')


#: Gravitational parameter giving mean motion 1 rad/s at 7000 km (a strong gradient).
STRONG_GRADIENT_MU = 7.0e6 ** 3


def gravity_gradient_case(quick: bool) -> DynamicsCase:
    """The triaxial Hairer–Vilmart body under a strong gravity gradient."""
    scene = body_scene('gravity_gradient', HAIRER_VILMART, quat.exp([0.3, -0.2, 0.1]).tolist(),
                       HAIRER_VILMART_OMEGA,
                       [{'gravity_gradient': {'orbit_radius': 7.0e6, 'mu': STRONG_GRADIENT_MU}}])
    counts = _sweeps(quick, (100, 400) if quick else (100, 200, 400, 800, 1600), special={
        'casimir6': (100, 200, 400, 800), 'casimir8': (25, 50, 75, 100),
        'rkn4': (20, 40, 80, 160), 'rkn6': (20, 40, 80, 120)})
    return DynamicsCase('gravity_gradient', scene, 10.0, counts,
                        (1e-8,) if quick else (1e-6, 1e-8, 1e-10),
                        (1e-8, 1e-10) if quick else (1e-7, 1e-8, 1e-9, 1e-10, 1e-11),
                        'kinetic energy error (rel.)')


def command_schedule(duration: float, period: float = 0.1) -> Schedule:
    """A smooth torque profile sampled every ``period`` seconds and held [N m, body]."""
    count = int(round(duration / period))
    return [(k * period, (0.2 * math.sin(1.1 * k * period), 0.1 * math.cos(0.7 * k * period),
                          0.05)) for k in range(count)]


def commanded_torque_case(quick: bool) -> DynamicsCase:
    """The triaxial body under a torque commanded at 10 Hz (``commanded_torque``)."""
    scene = body_scene('commanded_torque', HAIRER_VILMART, (1.0, 0.0, 0.0, 0.0),
                       HAIRER_VILMART_OMEGA, [{'commanded_torque': {'timeout': 0.5}}])
    return DynamicsCase('commanded_torque', scene, 10.0,
                        _sweeps(quick, (100, 400) if quick else (100, 200, 400, 800, 1600),
                                (100, 200)),
                        (1e-8,) if quick else (1e-6, 1e-8, 1e-10),
                        (1e-8,) if quick else (1e-7, 1e-9, 1e-11),
                        'kinetic energy error (rel.)', command_schedule(10.0))


DYNAMICS_CASES: dict[str, Callable[[bool], DynamicsCase]] = {
    'torque_free': torque_free_case,
    'near_separatrix': near_separatrix_case,
    'heavy_top': heavy_top_case,
    'gravity_gradient': gravity_gradient_case,
    'commanded_torque': commanded_torque_case,
}
