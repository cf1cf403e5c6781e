"""Accuracy / work-precision study of the integrator menu: what accuracy costs in time.

``accuracy_study [--output DIR] [--cases a,b] [--quick]`` sweeps the step of every applicable
method over a standard set of cases, measures the error against a closed form or a reference
at least 100× more accurate, the CPU time (``time.process_time``, best of three repeats for
runs under 0.2 s, of five under 20 ms) per simulated second and an invariant's drift, and writes

* ``results.csv`` — one row per (case, method, step);
* ``README.md`` — tables per case and the heavy-top comparison with scipy's DOP853;
* ``work_precision.png`` — log-log error vs CPU time, one line per method, one panel per
  case, plus invariant-drift panels.

Cases (conventions of :mod:`rigid_body_attitude.core.quaternion`):

``coning``
    classical coning, half-angle 0.05 rad at 2 Hz, T = 10 s, strapdown stream methods; error
    vs the closed form (physics.md §2.3); invariant: coning drift about the cone axis.
``generic``
    a smooth wandering rate, T = 4 s: ω(t) methods, stream methods (rate and delta-angle
    samples) and the Euler/Bryant/DCM forms; reference DOP853 at rtol 2.3e−14.
``gimbal``
    a rate taking the attitude within 0.02 rad of the Euler (ZXZ) singularity: the
    quaternion methods do not notice, the Euler-angle form loses accuracy or refuses.
``torque_free``
    Hairer–Vilmart body (physics.md §2.5), T = 10 s; exact reference; invariant: world
    angular momentum drift.
``near_separatrix``
    J = (1, 2, 3), m₀ = (1e−4, 2, 0), T = 30 s (several flips); exact reference.
``heavy_top``
    symmetric top on a pivot, J = diag(0.05, 0.05, 0.02) kg m², m g l = 0.981 N m, spin
    25 rad/s, T = 10 s; reference DOP853 at rtol 1e−13; also scipy's DOP853 itself over a
    tolerance sweep; invariant: total energy drift.
``commanded_torque``
    triaxial body under a time-varying body torque, T = 10 s; reference DOP853 at rtol 1e−13;
    invariant: kinetic-energy error.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from rigid_body_attitude.core import quaternion as quat
from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.core.integrators import (
    dynamics_integrator, KINEMATIC_METHODS, SimpleBodyModel, STRAPDOWN_METHODS,
    TorqueFreeMotion)
from rigid_body_attitude.core.integrators import angles

__all__ = ['CASES', 'Row', 'main', 'run_study']

FloatArray = NDArray[np.float64]

#: The error at which the heavy-top comparison with scipy's DOP853 is made [rad].
HEAVY_TOP_TARGET = 1e-9
DYNAMICS_METHODS = ('rk4', 'rkmk4', 'strang', 'yoshida4', 'casimir6', 'casimir8')
#: RKN splittings need the exact free flow (elliptic functions for a triaxial body, ~0.5 ms per
#: flow); torque-free they are the exact step, so they only appear in torque cases.
RKN_METHODS = ('rkn4', 'rkn6')


@dataclass
class Row:
    """One measurement: a method at one step (or tolerance) on one case."""

    case: str
    method: str
    family: str
    step: float
    steps: int
    error: float
    cpu: float
    duration: float
    invariant: str = ''
    drift: float = float('nan')
    note: str = ''

    @property
    def cpu_per_second(self) -> float:
        """CPU seconds per simulated second."""
        return self.cpu / self.duration


@dataclass
class Job:
    """A measurement to run: ``run() -> (error, drift, steps, note)``, timed inside."""

    case: str
    method: str
    family: str
    step: float
    duration: float
    run: Callable[[], tuple[Any, ...]]
    invariant: str = ''
    floor: float = 0.0


def _timed(function: Callable[[], Any]) -> tuple[float, Any]:
    """CPU seconds of ``function()`` (best of three below 0.2 s, of five below 20 ms, to
    shed the load of other processes) and its result."""
    best = math.inf
    result = None
    for attempt in range(5):
        start = time.process_time()
        result = function()
        elapsed = time.process_time() - start
        best = min(best, elapsed)
        if elapsed > 0.2 or (elapsed > 0.02 and attempt >= 2):
            break
    return best, result


# --------------------------------------------------------------------------------------------
# Rate-driven cases


CONE_ANGLE = 0.05
CONE_FREQUENCY = 2.0 * math.pi * 2.0


def coning_rate(t: float) -> tuple[float, float, float]:
    """Body rate of classical coning (physics.md §2.3)."""
    a, w = CONE_ANGLE, CONE_FREQUENCY
    return (-2.0 * w * math.sin(0.5 * a) ** 2, -w * math.sin(a) * math.sin(w * t),
            w * math.sin(a) * math.cos(w * t))


def coning_attitude(t: float) -> FloatArray:
    """Exact attitude of classical coning."""
    a, w = CONE_ANGLE, CONE_FREQUENCY
    return np.array([math.cos(0.5 * a), 0.0, math.sin(0.5 * a) * math.cos(w * t),
                     math.sin(0.5 * a) * math.sin(w * t)])


def coning_angle(t: float) -> FloatArray:
    """``∫₀ᵗ ω`` of classical coning, whose differences are the exact delta angles."""
    a, w = CONE_ANGLE, CONE_FREQUENCY
    return np.array([-2.0 * w * t * math.sin(0.5 * a) ** 2, math.sin(a) * (math.cos(w * t) - 1),
                     math.sin(a) * math.sin(w * t)])


def generic_rate(t: float) -> tuple[float, float, float]:
    """A smooth rate whose direction wanders (no coning symmetry) [rad/s]."""
    return (0.7 * math.sin(1.3 * t) + 0.2, 0.5 * math.cos(2.1 * t) - 0.075 * t,
            0.4 + 0.6 * math.sin(0.7 * t + 1.0))


def generic_angle(t: float) -> FloatArray:
    """``∫₀ᵗ generic_rate``."""
    return np.array((-0.7 / 1.3 * math.cos(1.3 * t) + 0.2 * t,
                     0.5 / 2.1 * math.sin(2.1 * t) - 0.0375 * t * t,
                     0.4 * t - 0.6 / 0.7 * math.cos(0.7 * t + 1.0)))


def gimbal_rate(t: float) -> tuple[float, float, float]:
    """A rate that tips the body through (almost) the ZXZ singularity near t = 2 s."""
    return (-0.2, 0.02 * math.cos(t), 0.05)


def _quaternion_reference(rate: Callable[[float], Sequence[float]], initial: FloatArray,
                          duration: float) -> tuple[FloatArray, float]:
    """DOP853 at rtol 2.3e−14 on ``q̇ = ½ q ⊗ (0, ω(t))`` and the error floor it allows.

    The floor is 100× the reference's error, estimated as a tenth of its difference from a
    run at a ten times looser tolerance (DOP853's error scales like the tolerance).
    """
    def solve(rtol: float) -> FloatArray:
        solution = solve_ivp(
            lambda t, q: 0.5 * quat.multiply(q, np.concatenate([[0.0], rate(t)])),
            (0.0, duration), initial, method='DOP853', rtol=rtol, atol=1e-3 * rtol)
        return quat.normalize(solution.y[:, -1])
    reference = solve(2.3e-14)
    return reference, 10.0 * max(quat.attitude_error(reference, solve(2.3e-13)), 1e-16)


def _dop853_reference(rhs: Callable[[float, FloatArray], FloatArray], start: FloatArray,
                      duration: float) -> tuple[FloatArray, float]:
    """DOP853 at rtol 1e−13 on the full state and the error floor it allows (as above)."""
    def solve(rtol: float) -> FloatArray:
        return solve_ivp(rhs, (0.0, duration), start, method='DOP853', rtol=rtol,
                         atol=1e-2 * rtol).y[:, -1]
    reference = solve(1e-13)
    looser = solve(1e-12)
    return reference, 10.0 * max(quat.attitude_error(reference[:4], looser[:4]), 1e-16)


def _stream_run(name: str, rate: Callable[[float], Sequence[float]],
                angle: Callable[[float], FloatArray], initial: FloatArray, duration: float,
                steps: int) -> Callable[[], FloatArray]:
    """A closure feeding ``steps`` samples to a fresh strapdown method."""
    h = duration / steps
    samples = [rate(k * h) for k in range(steps + 1)]
    integrals = [angle(k * h) for k in range(steps + 1)]
    deltas = [tuple(((b - a) / h).tolist()) for a, b in zip(integrals, integrals[1:])]
    start = tuple(initial.tolist())

    def run() -> FloatArray:
        method = STRAPDOWN_METHODS[name]()
        q = start
        if method.input_kind == 'rate':
            for k in range(steps):
                q = method.propagate(q, samples[k], samples[k + 1], h)
        else:
            for k in range(steps):
                q = method.propagate(q, None, deltas[k], h)
        return np.array(q)
    return run


def coning_jobs(quick: bool) -> list[Job]:
    """Strapdown stream methods on classical coning."""
    duration = 2.0 if quick else 10.0
    counts = (100, 400) if quick else (100, 200, 400, 800, 1600, 3200)
    truth = coning_attitude(duration)
    jobs = []
    for name in STRAPDOWN_METHODS:
        for steps in counts:
            run = _stream_run(name, coning_rate, coning_angle, coning_attitude(0.0), duration,
                              steps)

            def measure(run=run) -> tuple[Any, ...]:
                final = run()
                # A whole number of cycles: the error's axial part over the run, per unit time,
                # is the mean coning drift (plus the bounded error divided by the duration).
                along_axis = quat.log(quat.multiply(quat.conjugate(final), truth))[0]
                return quat.attitude_error(final, truth), along_axis / duration, None, ''
            # Closed form: error ~ a few ulps of Ωt ≈ 1e−14, so errors ≥ 1e−12 are resolved.
            jobs.append(Job('coning', name, 'strapdown', duration / steps, duration, measure,
                            'coning drift [rad/s]', 1e-12))
    return jobs


def generic_jobs(quick: bool) -> list[Job]:
    """ω(t) methods, stream methods and angle forms on the generic rate."""
    duration = 4.0
    initial = quat.normalize([0.8, 0.3, -0.2, 0.4])
    reference, floor = _quaternion_reference(generic_rate, initial, duration)
    counts = (40, 160) if quick else (40, 80, 160, 320, 640)
    jobs = []
    for name, method in KINEMATIC_METHODS.items():
        for steps in counts:
            def measure(method=method, steps=steps) -> tuple[Any, ...]:
                q = method.integrate(tuple(initial.tolist()), generic_rate, 0.0,
                                     duration / steps, steps)
                return quat.attitude_error(np.array(q), reference), float('nan'), None, ''
            jobs.append(Job('generic', f'{name} (ω(t))', 'kinematic', duration / steps,
                            duration, measure))
    for name in STRAPDOWN_METHODS:
        for steps in counts:
            run = _stream_run(name, generic_rate, generic_angle, initial, duration, steps)

            def measure(run=run) -> tuple[Any, ...]:
                return quat.attitude_error(run(), reference), float('nan'), None, ''
            jobs.append(Job('generic', f'{name} (samples)', 'strapdown', duration / steps,
                            duration, measure))
    jobs += _angle_jobs('generic', generic_rate, initial, reference, duration, counts)
    for job in jobs:
        job.floor = floor
    return jobs


def _angle_jobs(case: str, rate: Callable[[float], Sequence[float]], initial: FloatArray,
                reference: FloatArray, duration: float, counts: Sequence[int]) -> list[Job]:
    """Euler, Bryant and DCM forms (RK4), reporting a refused singular step as a note."""
    forms: list[tuple[str, Callable[..., Any], Callable[[Any], Any], Any]] = [
        ('euler_zxz_rk4', angles.euler_zxz_rk4_step, quat.from_euler_zxz,
         tuple(quat.as_euler_zxz(initial).tolist())),
        ('bryant_xyz_rk4', angles.bryant_xyz_rk4_step, quat.from_bryant_xyz,
         tuple(quat.as_bryant_xyz(initial).tolist())),
        ('dcm_rk4', angles.dcm_poisson_rk4_step, _dcm_to_quaternion, quat.to_matrix(initial)),
        ('dcm_rk4_orthonormalised',
         lambda a, w, t, h: angles.dcm_poisson_rk4_step(a, w, t, h, orthonormalize=True),
         _dcm_to_quaternion, quat.to_matrix(initial)),
    ]
    jobs = []
    for name, step, to_quaternion, start in forms:
        for steps in counts:
            def measure(step=step, to_quaternion=to_quaternion, start=start,
                        steps=steps) -> tuple[Any, ...]:
                h = duration / steps
                state = start
                try:
                    for k in range(steps):
                        state = step(state, rate, k * h, h)
                except AttitudeError as err:
                    return math.nan, math.nan, None, f'refused at t = {k * h:.3f} s: {err}'
                q = to_quaternion(np.array(state))
                return quat.attitude_error(q, reference), math.nan, None, ''
            jobs.append(Job(case, name, 'angles', duration / steps, duration, measure))
    return jobs


def _dcm_to_quaternion(matrix: FloatArray) -> FloatArray:
    """Nearest rotation (SVD) of a possibly non-orthogonal DCM, as a quaternion."""
    u, _, vt = np.linalg.svd(matrix)
    return quat.from_matrix(u @ vt)


def gimbal_jobs(quick: bool) -> list[Job]:
    """Quaternion vs angle forms on a path through the Euler singularity."""
    duration = 4.0
    initial = quat.exp([0.4, 0.0, 0.0])
    reference, floor = _quaternion_reference(gimbal_rate, initial, duration)
    counts = (40, 160) if quick else (40, 80, 160, 320, 640)
    jobs = []
    for name in ('rk4_quaternion', 'magnus4'):
        method = KINEMATIC_METHODS[name]
        for steps in counts:
            def measure(method=method, steps=steps) -> tuple[Any, ...]:
                q = method.integrate(tuple(initial.tolist()), gimbal_rate, 0.0,
                                     duration / steps, steps)
                return quat.attitude_error(np.array(q), reference), math.nan, None, ''
            jobs.append(Job('gimbal', f'{name} (ω(t))', 'kinematic', duration / steps, duration,
                            measure))
    jobs += _angle_jobs('gimbal', gimbal_rate, initial, reference, duration, counts)
    for job in jobs:
        job.floor = floor
    return jobs


# --------------------------------------------------------------------------------------------
# Dynamics cases


def _dynamics_job(case: str, name: str, model: SimpleBodyModel, initial: FloatArray,
                  omega: FloatArray, duration: float, steps: int,
                  evaluate: Callable[[FloatArray, FloatArray], tuple[float, float]],
                  invariant: str, options: dict[str, float] | None = None) -> Job:
    """Fixed-step (or one adaptive call) dynamics run and its error/invariant."""
    adaptive = name == 'dopri45'

    def measure() -> tuple[Any, ...]:
        integrator = dynamics_integrator(name, **(options or {}))
        note = ''
        if adaptive:
            q, w = integrator.step(initial, omega, 0.0, duration, model)
            count = integrator.steps_taken
            note = (f'rtol={integrator.rtol:.0e}, {integrator.evaluations} evaluations, '
                    f'{integrator.steps_rejected} rejected')
        else:
            q, w = integrator.integrate(initial, omega, 0.0, duration / steps, steps, model)
            count = steps
        error, drift = evaluate(q, w)
        return error, drift, count, note
    step = math.nan if adaptive else duration / steps
    return Job(case, name, 'dynamics', step, duration, measure, invariant)


def _exact_evaluator(moments: FloatArray, initial: FloatArray, omega: FloatArray,
                     duration: float) -> Callable[[FloatArray, FloatArray], tuple[float, float]]:
    motion = TorqueFreeMotion(moments, initial, omega_body=omega)
    expected_q, _ = motion.state(duration)
    world = motion.world_angular_momentum()

    def evaluate(q: FloatArray, w: FloatArray) -> tuple[float, float]:
        drift = np.linalg.norm(quat.rotate(q, moments * w) - world) / np.linalg.norm(world)
        return quat.attitude_error(q, expected_q), float(drift)
    return evaluate


def torque_free_jobs(case: str, moments: Sequence[float], omega: Sequence[float],
                     duration: float, counts: Sequence[int], tolerances: Sequence[float]
                     ) -> list[Job]:
    """Dynamics methods (and the exact step) on a torque-free body."""
    moments = np.asarray(moments, dtype=np.float64)
    omega = np.asarray(omega, dtype=np.float64)
    initial = quat.identity()
    model = SimpleBodyModel(moments)
    evaluate = _exact_evaluator(moments, initial, omega, duration)
    invariant = 'world momentum drift (rel.)'
    jobs = [_dynamics_job(case, name, model, initial, omega, duration, steps, evaluate,
                          invariant) for name in DYNAMICS_METHODS for steps in counts]
    jobs += [_dynamics_job(case, 'dopri45', model, initial, omega, duration, 0, evaluate,
                           invariant, {'rtol': rtol, 'atol': 1e-3 * rtol})
             for rtol in tolerances]
    jobs.append(_dynamics_job(case, 'exact', model, initial, omega, duration, 1, evaluate,
                              invariant))
    for job in jobs:
        job.floor = 2e-12  # exact solution: a few ulps of ψ ≈ 2T t/G ≈ 1e−14 rad, ×100
    return jobs


HEAVY_TOP_MOMENTS = (0.05, 0.05, 0.02)
HEAVY_TOP_MGL = 9.81 * 0.1


def heavy_top_torque(t: float, attitude: Any, omega_body: Any) -> tuple[float, float, float]:
    """Gravity about the pivot, centre of mass at l e₃: ``m g l e₃ × R(q)ᵀ(−ẑ)`` [N m]."""
    qw, qx, qy, qz = attitude.tolist() if hasattr(attitude, 'tolist') else attitude
    # R(q)ᵀ(−ẑ) = −(2(xz − wy), 2(yz + wx), 1 − 2(x² + y²)); e₃ × g = (−g_y, g_x, 0).
    return (HEAVY_TOP_MGL * 2.0 * (qy * qz + qw * qx), -HEAVY_TOP_MGL * 2.0 * (qx * qz - qw * qy),
            0.0)


def heavy_top_energy(q: FloatArray, w: FloatArray) -> float:
    """Kinetic plus potential energy ``½ωᵀJω + m g l (R e₃)·ẑ`` [J]."""
    height = 1.0 - 2.0 * (q[1] ** 2 + q[2] ** 2)
    return float(0.5 * np.sum(np.array(HEAVY_TOP_MOMENTS) * w * w) + HEAVY_TOP_MGL * height)


def heavy_top_rhs(t: float, y: FloatArray) -> FloatArray:
    """Euler + Poisson equations of the heavy top in plain floats (scipy's right-hand side):
    ``y = (q, ω)`` (7,), the same :func:`heavy_top_torque` called with plain floats."""
    qw, qx, qy, qz, p, q, r = y.tolist()
    mx, my, mz = heavy_top_torque(t, (qw, qx, qy, qz), None)
    j1, j2, j3 = HEAVY_TOP_MOMENTS
    return np.array((0.5 * (-qx * p - qy * q - qz * r), 0.5 * (qw * p + qy * r - qz * q),
                     0.5 * (qw * q - qx * r + qz * p), 0.5 * (qw * r + qx * q - qy * p),
                     (mx - (j3 - j2) * q * r) / j1, (my - (j1 - j3) * r * p) / j2,
                     (mz - (j2 - j1) * p * q) / j3))


def heavy_top_jobs(quick: bool) -> list[Job]:
    """The symmetric heavy top: project methods and scipy's DOP853 vs a DOP853 reference."""
    duration = 2.0 if quick else 10.0
    initial = quat.exp([0.3, 0.0, 0.0])
    omega = np.array([0.0, 0.5, 25.0])
    start = np.concatenate([initial, omega])
    reference, floor = _dop853_reference(heavy_top_rhs, start, duration)
    expected_q = reference[:4]
    energy = heavy_top_energy(initial, omega)
    # The same torque function as scipy's right-hand side, called the same way (plain floats).
    model = SimpleBodyModel(HEAVY_TOP_MOMENTS, torque_body=heavy_top_torque,
                            torque_depends_on_rate=False, torque_takes_floats=True)

    def evaluate(q: FloatArray, w: FloatArray) -> tuple[float, float]:
        return (quat.attitude_error(q, expected_q),
                abs(heavy_top_energy(q, w) / energy - 1.0))
    invariant = 'energy drift (rel.)'
    counts = {'rk4': (2000, 4000, 8000, 16000), 'rkmk4': (2000, 4000, 8000, 16000),
              'strang': (1000, 4000, 16000), 'yoshida4': (500, 1000, 2000, 4000, 8000),
              'casimir6': (100, 200, 400, 800, 1600), 'casimir8': (60, 80, 100, 130, 160, 200,
                                                                   400),
              'rkn4': (100, 200, 400, 800, 1600), 'rkn6': (100, 150, 200, 250, 300, 400)}
    if quick:
        counts = {name: values[:2] for name, values in counts.items()}
    jobs = [_dynamics_job('heavy_top', name, model, initial, omega, duration, steps, evaluate,
                          invariant) for name, values in counts.items() for steps in values]
    tolerances = (1e-8, 1e-10) if quick else (1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
    jobs += [_dynamics_job('heavy_top', 'dopri45', model, initial, omega, duration, 0, evaluate,
                           invariant, {'rtol': rtol, 'atol': 1e-3 * rtol})
             for rtol in tolerances]
    for rtol in ((1e-8, 1e-10) if quick else (1e-8, 1e-9, 1e-10, 1e-11, 1e-12)):
        def measure(rtol=rtol) -> tuple[Any, ...]:
            result = solve_ivp(heavy_top_rhs, (0.0, duration), start, method='DOP853',
                               rtol=rtol, atol=1e-3 * rtol)
            q, w = quat.normalize(result.y[:4, -1]), result.y[4:, -1]
            error, drift = evaluate(q, w)
            return error, drift, len(result.t) - 1, f'rtol={rtol:.0e}, {result.nfev} f-evals'
        jobs.append(Job('heavy_top', 'scipy DOP853', 'scipy', math.nan, duration, measure,
                        invariant))
    for job in jobs:
        job.floor = floor
    return jobs


def _commanded_torque(t: float, attitude: Any, omega_body: Any) -> tuple[float, float, float]:
    """A body-fixed commanded torque profile [N m]."""
    return 0.2 * math.sin(1.1 * t), 0.1 * math.cos(0.7 * t), 0.05


def commanded_torque_jobs(quick: bool) -> list[Job]:
    """Triaxial body under a commanded torque; DOP853 reference at rtol 1e−13."""
    duration = 10.0
    moments = np.array([0.6, 0.8, 1.0])
    initial = quat.identity()
    omega = np.array([1.8, 0.4, -0.9]) / moments

    def rhs(t: float, y: FloatArray) -> FloatArray:
        q, w = y[:4], y[4:]
        torque = np.array(_commanded_torque(t, q, w))
        w_dot = (torque - np.cross(w, moments * w)) / moments
        return np.concatenate([0.5 * quat.multiply(q, np.concatenate([[0.0], w])), w_dot])
    reference, floor = _dop853_reference(rhs, np.concatenate([initial, omega]), duration)
    expected_q, expected_w = reference[:4], reference[4:]
    expected_energy = 0.5 * np.sum(moments * expected_w ** 2)
    model = SimpleBodyModel(moments, torque_body=_commanded_torque,
                            torque_depends_on_rate=False)

    def evaluate(q: FloatArray, w: FloatArray) -> tuple[float, float]:
        return (quat.attitude_error(q, expected_q),
                abs(0.5 * np.sum(moments * w * w) / expected_energy - 1.0))
    invariant = 'energy error (rel.)'
    counts = (100, 400) if quick else (100, 200, 400, 800, 1600)
    jobs = [_dynamics_job('commanded_torque', name, model, initial, omega, duration, steps,
                          evaluate, invariant) for name in DYNAMICS_METHODS for steps in counts]
    jobs += [_dynamics_job('commanded_torque', name, model, initial, omega, duration, steps,
                           evaluate, invariant)
             for name in RKN_METHODS for steps in ((10, 40) if quick else (10, 20, 40, 80))]
    jobs += [_dynamics_job('commanded_torque', 'dopri45', model, initial, omega, duration, 0,
                           evaluate, invariant, {'rtol': rtol, 'atol': 1e-3 * rtol})
             for rtol in ((1e-8,) if quick else (1e-6, 1e-8, 1e-10))]
    for job in jobs:
        job.floor = floor
    return jobs


CASES: dict[str, Callable[[bool], list[Job]]] = {
    'coning': coning_jobs,
    'generic': generic_jobs,
    'gimbal': gimbal_jobs,
    'torque_free': lambda quick: torque_free_jobs(
        'torque_free', [0.6, 0.8, 1.0], np.array([1.8, 0.4, -0.9]) / [0.6, 0.8, 1.0], 10.0,
        (100, 400) if quick else (50, 100, 200, 400, 800, 1600),
        (1e-8,) if quick else (1e-6, 1e-8, 1e-10, 1e-12)),
    'near_separatrix': lambda quick: torque_free_jobs(
        'near_separatrix', [1.0, 2.0, 3.0], [1e-4, 1.0, 0.0], 10.0 if quick else 30.0,
        (200, 800) if quick else (100, 200, 400, 800, 1600, 3200),
        (1e-8,) if quick else (1e-6, 1e-8, 1e-10, 1e-12)),
    'heavy_top': heavy_top_jobs,
    'commanded_torque': commanded_torque_jobs,
}


# --------------------------------------------------------------------------------------------
# Running and reporting


def run_study(cases: Sequence[str], quick: bool = False,
              progress: bool = True) -> list[Row]:
    """Run the named cases; returns one :class:`Row` per measurement."""
    jobs: list[Job] = []
    for case in cases:
        jobs += CASES[case](quick)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(jobs), desc='accuracy study', unit='run', file=sys.stderr)
    rows = []
    for job in jobs:
        cpu, (error, drift, count, note) = _timed(job.run)
        steps = count if count is not None else int(round(job.duration / job.step))
        if job.method == 'exact':
            note = 'the reference itself (closed form)'
        elif math.isfinite(error) and error < job.floor:
            note = (note + '; ' if note else '') + (
                f'below the reference floor {job.floor:.0e}: not resolved')
        rows.append(Row(job.case, job.method, job.family, job.step, steps, float(error), cpu,
                        job.duration, job.invariant, float(drift), note))
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    return rows


def cpu_at_error(rows: Sequence[Row], target: float) -> float:
    """CPU seconds to reach ``target`` error, log-log interpolated along a method's sweep
    (rows sorted by CPU); ``nan`` if the sweep never reaches it."""
    points = sorted((r.cpu, r.error) for r in rows if r.error > 0.0 and math.isfinite(r.error))
    for (c0, e0), (c1, e1) in zip(points, points[1:]):
        if e0 >= target >= e1 and e0 > e1:
            fraction = math.log(e0 / target) / math.log(e0 / e1)
            return math.exp(math.log(c0) + fraction * (math.log(c1) - math.log(c0)))
    reached = [c for c, e in points if e <= target]
    return min(reached) if reached else math.nan


def heavy_top_comparison(rows: Sequence[Row]) -> dict[str, float | str]:
    """CPU time to reach :data:`HEAVY_TOP_TARGET` per method, and the best/DOP853 ratio."""
    top = [r for r in rows if r.case == 'heavy_top']
    methods = sorted({r.method for r in top})
    cost = {m: cpu_at_error([r for r in top if r.method == m], HEAVY_TOP_TARGET)
            for m in methods}
    own = {m: c for m, c in cost.items() if m != 'scipy DOP853' and math.isfinite(c)}
    best = min(own, key=own.get) if own else ''
    scipy_cost = cost.get('scipy DOP853', math.nan)
    ratio = own[best] / scipy_cost if best and math.isfinite(scipy_cost) else math.nan
    return {'best': best, 'best_cpu': own.get(best, math.nan), 'scipy_cpu': scipy_cost,
            'ratio': ratio, **{f'cpu:{m}': c for m, c in cost.items()}}


def write_csv(rows: Sequence[Row], path: Path) -> None:
    """One line per measurement."""
    with path.open('w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(['case', 'method', 'family', 'step_s', 'steps', 'error_rad', 'cpu_s',
                         'cpu_per_simulated_s', 'invariant', 'invariant_drift', 'note'])
        for r in rows:
            writer.writerow([r.case, r.method, r.family, f'{r.step:.6g}', r.steps,
                             f'{r.error:.3e}', f'{r.cpu:.4e}', f'{r.cpu_per_second:.4e}',
                             r.invariant, f'{r.drift:.3e}', r.note])


def _fmt(value: float) -> str:
    return '–' if not math.isfinite(value) else f'{value:.2e}'


def write_markdown(rows: Sequence[Row], path: Path, elapsed: float) -> None:
    """Tables per case and the heavy-top comparison."""
    lines = ['# Accuracy study: what accuracy costs in time', '',
             'Generated by `accuracy_study` (rigid_body_attitude.tools.study); CPU time is '
             '`time.process_time` on this machine, best of three repeats for runs under 0.2 s '
             f'(five under 20 ms). Whole study: {elapsed:.0f} s. Errors are attitude errors '
             '(physics.md §1) at the end time against the closed form or a reference at least '
             '100× more accurate. Figure: `work_precision.png`; data: `results.csv`.', '']
    cases = list(dict.fromkeys(r.case for r in rows))
    if 'heavy_top' in cases:
        comparison = heavy_top_comparison(rows)
        lines += ['## Heavy top: CPU time to reach 1e−9 rad at the end time', '',
                  '| method | CPU time [ms] |', '|---|---|']
        for key, value in comparison.items():
            if key.startswith('cpu:'):
                lines.append(f'| {key[4:]} | {_fmt(1e3 * value)} |')
        lines += ['', f'Best project method: **{comparison["best"]}**, '
                  f'{_fmt(1e3 * comparison["best_cpu"])} ms vs scipy DOP853 '
                  f'{_fmt(1e3 * comparison["scipy_cpu"])} ms: ratio '
                  f'**{comparison["ratio"]:.3f}** (target ≤ 0.1), measured in the same run. '
                  'Both call the same gravity torque (`study.heavy_top_torque`) with plain-float '
                  'tuples: scipy through a plain-float right-hand side (`study.heavy_top_rhs`), '
                  'the splitting methods through their fused loop for an axisymmetric body '
                  '(the model declares `torque_takes_floats`). Same initial state, end time '
                  'and error definition (attitude error against DOP853 at rtol 1e−13).', '']
    for case in cases:
        subset = [r for r in rows if r.case == case]
        invariant = next((r.invariant for r in subset if r.invariant), '')
        lines += [f'## {case}', '', f'| method | step [s] | steps | error [rad] | CPU [s] | '
                  f'CPU per simulated s | {invariant or "invariant"} | note |',
                  '|---|---|---|---|---|---|---|---|']
        for r in subset:
            lines.append(f'| {r.method} | {r.step:.4g} | {r.steps} | {_fmt(r.error)} | '
                         f'{r.cpu:.2e} | {r.cpu_per_second:.2e} | {_fmt(r.drift)} | '
                         f'{r.note} |')
        lines.append('')
    path.write_text('\n'.join(lines), encoding='utf-8')


def write_figure(rows: Sequence[Row], path: Path) -> None:
    """Work-precision panels (error vs CPU per method) and invariant-drift panels."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    cases = list(dict.fromkeys(r.case for r in rows))
    drift_cases = [c for c in ('torque_free', 'heavy_top') if c in cases]
    panels = len(cases) + len(drift_cases)
    columns = min(4, panels)
    lines_of = (panels + columns - 1) // columns
    figure, axes = plt.subplots(lines_of, columns, figsize=(5.0 * columns, 4.2 * lines_of),
                                squeeze=False)
    flat = list(axes.ravel())
    for axis, case in zip(flat, cases + [f'{c} drift' for c in drift_cases]):
        drift = case.endswith(' drift')
        name = case[:-6] if drift else case
        subset = [r for r in rows if r.case == name]
        for method in dict.fromkeys(r.method for r in subset):
            points = sorted((r.cpu, r.drift if drift else r.error)
                            for r in subset if r.method == method)
            points = [(c, e) for c, e in points if e > 0.0 and math.isfinite(e)]
            if points:
                axis.loglog(*zip(*points), marker='o', markersize=3, label=method)
        axis.set_title(f'{name}: {subset[0].invariant}' if drift else name)
        axis.set_xlabel('CPU time [s]')
        axis.set_ylabel(subset[0].invariant if drift else 'attitude error [rad]')
        axis.grid(True, which='both', alpha=0.3)
        axis.legend(fontsize=6, ncol=2)
    for axis in flat[panels:]:
        axis.set_visible(False)
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)


def _parse(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog='accuracy_study', description='Accuracy / work-precision study of the '
        'integrators (error vs CPU time, invariant drift).')
    parser.add_argument('--output', default='accuracy_study_output',
                        help='folder for results.csv, README.md and work_precision.png')
    parser.add_argument('--cases', default=','.join(CASES),
                        help=f'comma-separated subset of: {", ".join(CASES)}')
    parser.add_argument('--quick', action='store_true',
                        help='two steps per method and shorter runs (a smoke test)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns 0, or 2 with an ``error:`` line for bad arguments."""
    try:
        args = _parse(argv)
    except SystemExit as exit_request:
        return int(exit_request.code or 0)
    cases = [c.strip() for c in args.cases.split(',') if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown or not cases:
        print(f'error: unknown case(s) {unknown or cases!r}; expected a comma-separated '
              f'subset of {", ".join(CASES)}', file=sys.stderr)
        return 2
    output = Path(args.output)
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        print(f'error: cannot create output folder {str(output)!r}: {err}', file=sys.stderr)
        return 2
    start = time.perf_counter()
    rows = run_study(cases, quick=args.quick, progress=not args.no_progress)
    elapsed = time.perf_counter() - start
    write_csv(rows, output / 'results.csv')
    write_markdown(rows, output / 'README.md', elapsed)
    write_figure(rows, output / 'work_precision.png')
    if 'heavy_top' in cases:
        comparison = heavy_top_comparison(rows)
        print(f'heavy top, 1e-9 rad: best {comparison["best"]} '
              f'{1e3 * comparison["best_cpu"]:.1f} ms, scipy DOP853 '
              f'{1e3 * comparison["scipy_cpu"]:.1f} ms, ratio {comparison["ratio"]:.3f}')
    print(f'wrote {output / "results.csv"}, {output / "README.md"}, '
          f'{output / "work_precision.png"} ({len(rows)} runs, {elapsed:.0f} s)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
