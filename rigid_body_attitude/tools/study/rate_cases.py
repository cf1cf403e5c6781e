"""Rate-driven cases: the body rate is given (a gyro stream or a function of time).

``coning``
    classical coning, half-angle 0.05 rad at 2 Hz, T = 10 s (20 cone periods), strapdown
    stream methods; error vs the closed form (Savage 1998); invariant: the coning drift
    (sign convention of :mod:`rigid_body_attitude.core.attitude.integrators.strapdown`), measured
    from the end of the first cone period to the end of the run.
``generic``
    a smooth wandering rate, T = 4 s: ω(t) methods, stream methods (rate and delta-angle
    samples) and the Euler/Bryant/DCM forms; reference DOP853 at rtol 2.3e−14.
``gimbal``
    a rate taking the attitude within 0.02 rad of the Euler (ZXZ) singularity: the
    quaternion methods do not notice, the Euler-angle form loses accuracy or refuses.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.core.attitude.integrators import KINEMATIC_METHODS, STRAPDOWN_METHODS
from rigid_body_attitude.core.attitude.integrators import angles
from rigid_body_attitude.tools.study.runner import Job, Outcome

__all__ = ['coning_jobs', 'generic_jobs', 'gimbal_jobs']

FloatArray = NDArray[np.float64]
Rate = Callable[[float], tuple[float, float, float]]
Quat = tuple[float, float, float, float]

CONE_ANGLE = 0.05
CONE_FREQUENCY = 2.0 * math.pi * 2.0
#: Closed form good to a few ulps of Ωt ≈ 1e−14 rad: errors ≥ 1e−12 are resolved.
CONING_FLOOR = 1e-12


def coning_rate(t: float) -> tuple[float, float, float]:
    """Body rate of classical coning about the x axis (Savage 1998) [rad/s]."""
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


def quaternion_reference(rate: Rate, initial: FloatArray,
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
    error = float(quat.attitude_error(reference, solve(2.3e-13)))
    return reference, 10.0 * max(error, 1e-16)


def stream_run(name: str, rate: Rate, angle: Callable[[float], FloatArray],
               initial: FloatArray, duration: float, steps: int,
               checkpoint: int = 0) -> Callable[[], tuple[FloatArray, FloatArray]]:
    """A closure feeding ``steps`` samples to a fresh strapdown method; it returns the
    attitude after ``checkpoint`` steps and at the end."""
    h = duration / steps
    samples = [rate(k * h) for k in range(steps + 1)]
    integrals = [angle(k * h) for k in range(steps + 1)]
    deltas = [tuple(((b - a) / h).tolist()) for a, b in zip(integrals, integrals[1:])]
    w, x, y, z = initial.tolist()
    start: Quat = (w, x, y, z)

    def run() -> tuple[FloatArray, FloatArray]:
        method = STRAPDOWN_METHODS[name]()
        q: Sequence[float] = start
        at_checkpoint: Sequence[float] = start
        for k in range(steps):
            if method.input_kind == 'rate':
                q = method.propagate(q, samples[k], samples[k + 1], h)
            else:
                q = method.propagate(q, None, deltas[k], h)
            if k + 1 == checkpoint:
                at_checkpoint = q
        return np.array(at_checkpoint), np.array(q)
    return run


def _axial_error(q: FloatArray, truth: FloatArray) -> float:
    """Cone-axis (x) component of ``log(q* ⊗ q_true)`` [rad]."""
    return float(quat.log(quat.multiply(quat.conjugate(q), truth))[0])


def coning_jobs(quick: bool) -> list[Job]:
    """Strapdown stream methods on classical coning."""
    duration = 2.0 if quick else 10.0
    period = 2.0 * math.pi / CONE_FREQUENCY
    counts = (100, 400) if quick else (100, 200, 400, 800, 1600, 3200)
    truth, truth_first = coning_attitude(duration), coning_attitude(period)
    jobs = []
    for name in STRAPDOWN_METHODS:
        for steps in counts:
            first = int(round(steps * period / duration))  # a whole number of steps
            run = stream_run(name, coning_rate, coning_angle, coning_attitude(0.0), duration,
                             steps, first)

            def measure(run: Callable[[], tuple[FloatArray, FloatArray]] = run) -> Outcome:
                early, final = run()
                # Between ends of whole cone periods the bounded error cancels: the change of
                # the axial error per unit time is the coning drift.
                drift = (_axial_error(final, truth) - _axial_error(early, truth_first)) / (
                    duration - period)
                return Outcome(float(quat.attitude_error(final, truth)), drift)
            jobs.append(Job('coning', name, 'strapdown', duration / steps, duration, measure,
                            'coning drift [rad/s]', CONING_FLOOR))
    return jobs


def _kinematic_jobs(case: str, names: Sequence[str], rate: Rate, initial: FloatArray,
                    reference: FloatArray, duration: float, counts: Sequence[int]) -> list[Job]:
    """ω(t) methods: ``method.integrate`` over the run."""
    w, x, y, z = initial.tolist()
    jobs = []
    for name in names:
        method = KINEMATIC_METHODS[name]
        for steps in counts:
            def measure(method: Any = method, steps: int = steps) -> Outcome:
                q = method.integrate((w, x, y, z), rate, 0.0, duration / steps, steps)
                return Outcome(float(quat.attitude_error(np.array(q), reference)))
            jobs.append(Job(case, f'{name} (ω(t))', 'kinematic', duration / steps, duration,
                            measure))
    return jobs


def generic_jobs(quick: bool) -> list[Job]:
    """ω(t) methods, stream methods and angle forms on the generic rate."""
    duration = 4.0
    initial = quat.normalize([0.8, 0.3, -0.2, 0.4])
    reference, floor = quaternion_reference(generic_rate, initial, duration)
    counts = (40, 160) if quick else (40, 80, 160, 320, 640)
    jobs = _kinematic_jobs('generic', list(KINEMATIC_METHODS), generic_rate, initial,
                           reference, duration, counts)
    for name in STRAPDOWN_METHODS:
        for steps in counts:
            run = stream_run(name, generic_rate, generic_angle, initial, duration, steps)

            def measure(run: Callable[[], tuple[FloatArray, FloatArray]] = run) -> Outcome:
                return Outcome(float(quat.attitude_error(run()[1], reference)))
            jobs.append(Job('generic', f'{name} (samples)', 'strapdown', duration / steps,
                            duration, measure))
    jobs += angle_jobs('generic', generic_rate, initial, reference, duration, counts)
    for job in jobs:
        job.floor = floor
    return jobs


def _dcm_to_quaternion(matrix: FloatArray) -> FloatArray:
    """Nearest rotation (SVD) of a possibly non-orthogonal DCM, as a quaternion."""
    u, _, vt = np.linalg.svd(matrix)
    return quat.from_matrix(u @ vt)


def _orthonormalised_dcm_step(a: FloatArray, w: Rate, t: float, h: float) -> FloatArray:
    return angles.dcm_poisson_rk4_step(a, w, t, h, orthonormalize=True)


def _angle_forms(initial: FloatArray) -> list[tuple[str, Callable[..., Any],
                                                    Callable[[FloatArray], FloatArray], Any]]:
    """(name, step, to-quaternion, start) of the Euler, Bryant and DCM forms."""
    return [
        ('euler_zxz_rk4', angles.euler_zxz_rk4_step, quat.from_euler_zxz,
         tuple(quat.as_euler_zxz(initial).tolist())),
        ('bryant_xyz_rk4', angles.bryant_xyz_rk4_step, quat.from_bryant_xyz,
         tuple(quat.as_bryant_xyz(initial).tolist())),
        ('dcm_rk4', angles.dcm_poisson_rk4_step, _dcm_to_quaternion, quat.to_matrix(initial)),
        ('dcm_rk4_orthonormalised', _orthonormalised_dcm_step, _dcm_to_quaternion,
         quat.to_matrix(initial)),
    ]


def angle_jobs(case: str, rate: Rate, initial: FloatArray, reference: FloatArray,
               duration: float, counts: Sequence[int]) -> list[Job]:
    """Euler, Bryant and DCM forms (RK4), reporting a refused singular step as a note."""
    jobs = []
    for name, step, to_quaternion, start in _angle_forms(initial):
        for steps in counts:
            def measure(step: Callable[..., Any] = step,
                        to_quaternion: Callable[[FloatArray], FloatArray] = to_quaternion,
                        start: Any = start, steps: int = steps) -> Outcome:
                h = duration / steps
                state = start
                for k in range(steps):
                    try:
                        state = step(state, rate, k * h, h)
                    except AttitudeError as err:
                        return Outcome(math.nan, note=f'refused at t = {k * h:.3f} s: {err}')
                q = to_quaternion(np.array(state))
                return Outcome(float(quat.attitude_error(q, reference)))
            jobs.append(Job(case, name, 'angles', duration / steps, duration, measure))
    return jobs


def gimbal_jobs(quick: bool) -> list[Job]:
    """Quaternion vs angle forms on a path through the Euler singularity."""
    duration = 4.0
    initial = quat.exp([0.4, 0.0, 0.0])
    reference, floor = quaternion_reference(gimbal_rate, initial, duration)
    counts = (40, 160) if quick else (40, 80, 160, 320, 640)
    jobs = _kinematic_jobs('gimbal', ('rk4_quaternion', 'magnus4'), gimbal_rate, initial,
                           reference, duration, counts)
    jobs += angle_jobs('gimbal', gimbal_rate, initial, reference, duration, counts)
    for job in jobs:
        job.floor = floor
    return jobs
