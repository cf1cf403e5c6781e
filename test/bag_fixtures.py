"""Analytic input bags for the replay tests: five motions with closed-form attitudes.

Each :class:`AnalyticCase` holds a scene (a mapping, written to YAML for the replay tool and
the node), the input samples and the closed-form reference. :func:`write_case_bag` writes the
samples with :func:`rigid_body_attitude.bag.write_bag` (the package's helper for turning
arrays into a bag, usable for any user data) together with the closed-form attitude as ground
truth (``geometry_msgs/QuaternionStamped`` on ``ground_truth``), so ``replay --ground-truth``
reports the error against the exact solution directly.

Cases (closed forms of the quaternion kinematics q̇ = ½ q ⊗ (0, ω): Shuster, "A survey of attitude
representations", J. Astronaut. Sci. 41(4), 1993):

* ``constant_rate`` (gyro): ``q(τ) = q₀ ⊗ exp(τ ω)`` — the exponential map is exact.
* ``coning`` (gyro): classical coning, half-angle ``a``, frequency ``Ω`` (Savage, "Strapdown
inertial navigation integration algorithm design, part 1: attitude algorithms", JGCD 21(1), 1998).
* ``generic_rate`` (gyro): ``q(τ) = exp(f(τ) â) ⊗ q₀ ⊗ exp(g(τ) b̂)`` with non-linear ``f, g``
  (a regular precession, Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §36, with varying rates);
  its body rate
  ``ω = f′ R(q)ᵀ â + g′ b̂`` changes magnitude and direction, so it is not a coning motion.
* ``torque_free`` (dynamics): the Hairer–Vilmart body tumbling torque-free; exact solution
  from :class:`~rigid_body_attitude.core.dynamics.integrators.exact_torque_free.TorqueFreeMotion`.
  The bag
  holds only the ground truth, which gives the replay its time axis.
* ``constant_torque`` (dynamics): a constant commanded torque ``M`` about the principal axis
  ``e_z`` of a body spinning about it: ``q(τ) = q₀ ⊗ exp(θ e_z)``, ``θ = ω₀τ + Mτ²/(2J_z)``
  (§2.1). Commands (``WrenchStamped`` on ``torque``) come at 20 Hz, held 0.5 s, so the torque
  never lapses; one command per 100 Hz tick interval at most.

``τ`` is the time since the first output: the first gyro sample (baseline) for gyro scenes,
the first clock tick (scene start) for dynamics scenes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.bag import BagWriter, write_bag
from rigid_body_attitude.msgs import stamp_to_ns
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion

__all__ = ['AnalyticCase', 'CASES', 'GROUND_TRUTH_TOPIC', 'build_case', 'write_case_bag',
           'write_records', 'write_scene']

GROUND_TRUTH_TOPIC = 'ground_truth'
#: Gyro rate of the gyro cases [Hz] and samples per bag (2 s).
GYRO_RATE = 1000.0
GYRO_SAMPLES = 2000
#: Commands per second of the torque case, and its duration [s].
COMMAND_RATE = 20.0
DYNAMICS_DURATION = 2.0
#: Unit round-off of float64.
EPSILON = np.finfo(np.float64).eps

Reference = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class AnalyticCase:
    """An input bag's content and its closed-form attitude.

    Attributes:
        name: case name.
        scene: the scene as a mapping (the YAML content).
        stamps: header stamps = bag times of the input messages [s].
        rates: gyro rates (N, 3) [rad/s, body] or ``None``.
        torques: commanded torques (N, 3) [N m, body] or ``None``.
        attitude: ``τ ↦ q(τ)`` (vectorised, ``(..., 4)``), τ seconds after the first output.
        omega_body: ``τ ↦ ω(τ)`` [rad/s] (vectorised).
        tolerance: bound on the attitude error [rad] of the scene's integrator at the case's
            step over the whole bag; ``tolerance_reason`` says where it comes from.
        tolerance_reason: the justification of ``tolerance``.
    """

    name: str
    scene: dict[str, Any]
    stamps: np.ndarray
    rates: np.ndarray | None
    torques: np.ndarray | None
    attitude: Reference
    omega_body: Reference
    tolerance: float
    tolerance_reason: str

    @property
    def rate_source(self) -> str:
        """``'gyro'`` or ``'dynamics'``."""
        return self.scene['rate_source']


def _exact_stamps(start: float, rate: float, count: int) -> np.ndarray:
    """Stamps ``start + i/rate`` that survive the float → ns conversion of the bag exactly."""
    start_ns = stamp_to_ns(start)
    step_ns = round(1e9 / rate)
    return np.array([(start_ns + i * step_ns) * 1e-9 for i in range(count)])


def _relative_times(stamps: np.ndarray) -> np.ndarray:
    """τ of each stamp from the integer nanoseconds the bag holds."""
    nanoseconds = np.array([stamp_to_ns(t) for t in stamps.tolist()], dtype=np.int64)
    return (nanoseconds - nanoseconds[0]) * 1e-9


def _gyro_scene(name: str, initial_attitude: np.ndarray) -> dict[str, Any]:
    return {
        'name': name,
        'description': f'analytic replay case {name}',
        'rate_source': 'gyro',
        'integrator': 'exp_map',
        'body': {'mass': 1.0, 'inertia': {'moments': [0.6, 0.8, 1.0]}},
        'initial_state': {'attitude': initial_attitude.tolist()},
        'effects': [],
    }


def _held_rate_bound(omega: Reference, duration: float, h: float) -> tuple[float, str]:
    """Global error bound of the held-rate exponential map ``q ⊗ exp(h ω_k)`` (order 1).

    The exact rotation over ``[t_k, t_k + h]`` is ``h ω_k + (h²/2) ω̇ + (h³/6) ω̈
    + (h³/12) ω × ω̇ + O(h⁴)`` (Magnus series); holding ``ω_k`` drops all but the first term,
    so the error summed over the steps is at most ``(h/2) ∫|ω̇| dt + h² T (max|ω̈|/6
    + max|ω| max|ω̇|/12)``. Derivatives are taken on a grid 10× finer than the samples.
    """
    fine = np.linspace(0.0, duration, int(round(10 * duration / h)) + 1)
    dt = fine[1] - fine[0]
    rates = omega(fine)
    first = np.gradient(rates, dt, axis=0)
    second = np.gradient(first, dt, axis=0)
    first_norm = np.linalg.norm(first, axis=1)
    variation = float(np.sum(0.5 * (first_norm[1:] + first_norm[:-1])) * dt)
    bound = (0.5 * h * variation + h * h * duration * (
        np.linalg.norm(second, axis=1).max() / 6.0
        + np.linalg.norm(rates, axis=1).max() * first_norm.max() / 12.0))
    reason = (f'held-rate exp map, order 1: (h/2)∫|ω̇|dt + h²T(max|ω̈|/6 + max|ω||ω̇|/12) '
              f'= {bound:.3g} rad at h = {h:g} s, T = {duration:g} s')
    return float(bound), reason


def constant_rate_case() -> AnalyticCase:
    """Constant body rate: the exponential map is exact, only round-off remains."""
    stamps = _exact_stamps(100.0, GYRO_RATE, GYRO_SAMPLES)
    tau = _relative_times(stamps)
    omega = np.array([1.3, -0.7, 2.1])
    q0 = quaternion.normalize([0.9, 0.1, -0.3, 0.2])

    def attitude(t: np.ndarray) -> np.ndarray:
        return quaternion.multiply(q0, quaternion.exp(np.multiply.outer(t, omega)))

    def omega_body(t: np.ndarray) -> np.ndarray:
        return np.broadcast_to(omega, np.shape(t) + (3,)).copy()

    # Each step multiplies by exp(h ω) and renormalises: a few ulps per step, N steps.
    tolerance = 10.0 * GYRO_SAMPLES * EPSILON
    return AnalyticCase('constant_rate', _gyro_scene('constant_rate', q0), stamps,
                        omega_body(tau), None, attitude, omega_body, tolerance,
                        f'exact update, round-off only: 10 ulps × {GYRO_SAMPLES} steps')


def coning_case() -> AnalyticCase:
    """Classical coning (Savage 1998): half-angle 0.2 rad at 1.5 Hz."""
    half_angle, frequency = 0.2, 2.0 * np.pi * 1.5
    stamps = _exact_stamps(250.0, GYRO_RATE, GYRO_SAMPLES)
    tau = _relative_times(stamps)

    def attitude(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        return np.stack([np.full_like(t, np.cos(half_angle / 2)), np.zeros_like(t),
                         np.sin(half_angle / 2) * np.cos(frequency * t),
                         np.sin(half_angle / 2) * np.sin(frequency * t)], axis=-1)

    def omega_body(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        return np.stack([np.full_like(t, -2 * frequency * np.sin(half_angle / 2) ** 2),
                         -frequency * np.sin(half_angle) * np.sin(frequency * t),
                         frequency * np.sin(half_angle) * np.cos(frequency * t)], axis=-1)

    duration = float(tau[-1])
    tolerance, reason = _held_rate_bound(omega_body, duration, 1.0 / GYRO_RATE)
    return AnalyticCase('coning', _gyro_scene('coning', attitude(np.array(0.0))), stamps,
                        omega_body(tau), None, attitude, omega_body, tolerance, reason)


def generic_rate_case() -> AnalyticCase:
    """Two-axis composition with non-linear angles: a generic time-varying body rate."""
    axis_world = np.array([1.0, 2.0, 2.0]) / 3.0
    axis_body = np.array([0.3, -1.0, 0.5]) / np.linalg.norm([0.3, -1.0, 0.5])
    q0 = quaternion.normalize([0.5, -0.4, 0.7, 0.3])
    stamps = _exact_stamps(4321.5, GYRO_RATE, GYRO_SAMPLES)
    tau = _relative_times(stamps)

    def angles(t: np.ndarray) -> tuple[np.ndarray, ...]:
        t = np.asarray(t, dtype=np.float64)
        f = 0.7 * t + 0.3 * np.sin(2.0 * t)
        g = 1.1 * t + 0.5 * (1.0 - np.cos(3.0 * t))
        return f, 0.7 + 0.6 * np.cos(2.0 * t), g, 1.1 + 1.5 * np.sin(3.0 * t)

    def attitude(t: np.ndarray) -> np.ndarray:
        f, _, g, _ = angles(t)
        return quaternion.multiply(
            quaternion.multiply(quaternion.exp(np.multiply.outer(f, axis_world)), q0),
            quaternion.exp(np.multiply.outer(g, axis_body)))

    def omega_body(t: np.ndarray) -> np.ndarray:
        _, f_rate, _, g_rate = angles(t)
        world_part = quaternion.rotate_inverse(attitude(t), np.broadcast_to(
            axis_world, np.shape(t) + (3,)))
        return f_rate[..., None] * world_part + g_rate[..., None] * axis_body

    duration = float(tau[-1])
    tolerance, reason = _held_rate_bound(omega_body, duration, 1.0 / GYRO_RATE)
    return AnalyticCase('generic_rate', _gyro_scene('generic_rate', q0), stamps,
                        omega_body(tau), None, attitude, omega_body, tolerance, reason)


def _dynamics_scene(name: str, moments: list[float], omega0: list[float],
                    effects: list[Any]) -> dict[str, Any]:
    return {
        'name': name,
        'description': f'analytic replay case {name}',
        'rate_source': 'dynamics',
        'integrator': 'rk4',
        'step': 0.001,
        'body': {'mass': 1.0, 'inertia': {'moments': moments}},
        'initial_state': {'attitude': [1.0, 0.0, 0.0, 0.0], 'omega_body': omega0},
        'effects': effects,
    }


def torque_free_case() -> AnalyticCase:
    """The Hairer–Vilmart body (J = 0.6, 0.8, 1.0; m₀ = 1.8, 0.4, −0.9) tumbling for 2 s."""
    moments, omega0 = [0.6, 0.8, 1.0], [3.0, 0.5, -0.9]
    motion = TorqueFreeMotion(moments, [1.0, 0.0, 0.0, 0.0], omega_body=omega0)
    stamps = _exact_stamps(100.0, GYRO_RATE, GYRO_SAMPLES)
    # RK4's global error ∝ h⁴ (2.6e−9 at h = 6.25e−3 over T = 10 on the Hairer–Vilmart body,
    # test_integrators_dynamics); at
    # h = 1e−3 over 2 s that scales to 2.6e−9 · (1/6.25)⁴ · 2/10 = 3.4e−13; round-off of
    # 2000 steps adds ~2000 · 10 ulps = 4.4e−12.
    tolerance = 1e-11
    return AnalyticCase('torque_free', _dynamics_scene('torque_free', moments, omega0, []),
                        stamps, None, None, motion.attitude, motion.omega_body, tolerance,
                        'RK4 order 4 at h = 1 ms (3.4e-13) plus round-off of 2000 steps')


def constant_torque_case() -> AnalyticCase:
    """A spinning body spun up by a constant torque about its spin axis (principal)."""
    moments, spin, torque = [0.2, 0.3, 0.4], 0.5, 0.08
    count = int(round(DYNAMICS_DURATION * COMMAND_RATE))
    stamps = _exact_stamps(100.0, COMMAND_RATE, count)
    torques = np.tile([0.0, 0.0, torque], (count, 1))
    axis = np.array([0.0, 0.0, 1.0])

    def angle(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        return spin * t + torque * t * t / (2.0 * moments[2])

    def attitude(t: np.ndarray) -> np.ndarray:
        return quaternion.exp(np.multiply.outer(angle(t), axis))

    def omega_body(t: np.ndarray) -> np.ndarray:
        rate = spin + torque * np.asarray(t, dtype=np.float64) / moments[2]
        return np.multiply.outer(rate, axis)

    scene = _dynamics_scene('constant_torque', moments, [0.0, 0.0, spin],
                            [{'commanded_torque': {'timeout': 0.5}}])
    # About a fixed principal axis the motion is ω̇ = M/J_z, θ̈ = ω̇: RK4 integrates the
    # linear ω and quadratic θ exactly; what remains is the renormalised quaternion's
    # round-off over 2000 steps.
    tolerance = 1e-11
    return AnalyticCase('constant_torque', scene, stamps, None, torques, attitude, omega_body,
                        tolerance, 'RK4 is exact for θ quadratic in t; round-off of 2000 steps')


#: Case name → builder.
CASES: dict[str, Callable[[], AnalyticCase]] = {
    'constant_rate': constant_rate_case,
    'coning': coning_case,
    'generic_rate': generic_rate_case,
    'torque_free': torque_free_case,
    'constant_torque': constant_torque_case,
}


def build_case(name: str) -> AnalyticCase:
    """The analytic case ``name`` (one of :data:`CASES`)."""
    return CASES[name]()


def write_scene(case: AnalyticCase, directory: Path) -> Path:
    """Write the case's scene as ``<directory>/<name>.yaml``; returns the path."""
    path = Path(directory) / f'{case.name}.yaml'
    path.write_text(yaml.safe_dump(case.scene, sort_keys=False), encoding='utf-8')
    return path


def write_case_bag(case: AnalyticCase, path: Path, storage: str = 'sqlite3',
                   gyro_topic: str = 'imu', torque_topic: str = 'torque') -> dict[str, int]:
    """Write the case's inputs and closed-form ground truth as a bag at ``path``.

    For gyro cases the ground truth at each stamp is ``q(τ)``; for dynamics cases it is
    ``q(τ)`` with τ from the first stamp, which is also the first clock tick of the replay
    (the stamps start on a multiple of the tick period). Returns the message count per topic.
    """
    truth = case.attitude(_relative_times(case.stamps))
    return write_bag(path, stamps=case.stamps, rates=case.rates, torques=case.torques,
                     ground_truth=truth, imu_topic=gyro_topic, torque_topic=torque_topic,
                     ground_truth_topic=GROUND_TRUTH_TOPIC, storage=storage)


def write_records(path: Path, topics: dict[str, str],
                  records: list[tuple[str, int, bytes]], storage: str = 'sqlite3') -> None:
    """Write raw records ``(topic, bag_time_ns, cdr_bytes)`` as a bag with the real rosbag2
    writer (:class:`~rigid_body_attitude.bag.BagWriter`), whatever the bytes hold: for
    malformed or hostile messages that :func:`~rigid_body_attitude.bag.write_bag` refuses.

    ``topics`` maps each topic to its message type.
    """
    with BagWriter(path, storage=storage) as writer:
        connections = writer.add_topics(topics)
        for topic, bag_time_ns, data in records:
            writer.write(connections[topic], bag_time_ns, data)
