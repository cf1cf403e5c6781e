"""Hard case 3: the intermediate axis, J = (1, 2, 3), m₀ = (1e−4, 2, 0) (docs/hard-cases.md §3).

The body flips every 2K/|λ| = 36.7 s (Dzhanibekov effect). m₀ sits 1e−8 inside the separatrix
(Δ₂ = G² − 2T J₂ = −1e−8 with G² = 4): a method whose energy or |m| error moves Δ₂ by more than
that crosses to the other side and flips about the other axis; a smaller error δΔ₂ still
shifts every flip by δt ≈ (1/|λ|) δΔ₂/|Δ₂| (Landau & Lifshitz, *Mechanics*, 3rd ed., 1976, §37: the
flip period 2K/|λ|), an amplification of 1.7e8 s per
unit relative error. That amplification also applies to round-off: 10⁵ steps with a few ε of
invariant round-off each move the flips by ~1e−5 s whatever the method's order.

Flip times are the zeros of m₂(t). The exact ones come from the closed form (root-found to
1e−14 s); a method's are found with its own one-step map from the last state before the sign
change (the method's natural dense output, local error O(h^{p+1})).

Bounds after 10 flips are stated per method below: the method's error at its order where
that dominates, the round-off floor (1e−4 s) where it does not. No method crosses the
separatrix at the steps tested, and neither does the ``dzhanibekov`` scene's RK4 at 1 ms.
"""

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipkm1

from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator, SimpleBodyModel
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import (
    torque_free_invariants, TorqueFreeMotion)
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene

INERTIA = np.array([1.0, 2.0, 3.0])
MOMENTUM = np.array([1e-4, 2.0, 0.0])
Q0 = np.array([1.0, 0.0, 0.0, 0.0])
FLIPS = 10
CHUNK = 50  # steps advanced between sign checks (plain-float loop inside the integrator)


def exact_flip_times():
    """The first 10 zeros of m₂(t) of the closed-form solution [s]."""
    motion = TorqueFreeMotion(INERTIA, Q0, momentum_body=MOMENTUM)
    grid = np.arange(0.0, 400.0, 0.05)
    m2 = motion.momentum_body(grid)[:, 1]
    changes = np.flatnonzero(np.sign(m2[:-1]) != np.sign(m2[1:]))[:FLIPS]
    return np.array([brentq(lambda t: motion.momentum_body(t)[1], grid[i], grid[i + 1],
                            xtol=1e-14, rtol=4 * np.finfo(float).eps) for i in changes])


EXACT_FLIPS = exact_flip_times()


def numerical_flips(name, h, model=None, integrator=None):
    """Flip times of method ``name`` at step ``h``, whether it ever crossed the separatrix, and
    the largest Δ₂ seen at the chunk ends.

    Crossing shows as m₁ changing sign: on the starting side m₁ = σ B₁ dn(u) never does, on
    the other it changes sign every half period (36.7 s), so a check at every chunk end sees
    it. (The sign of the numerical Δ₂ is not the criterion: a splitting method keeps a
    modified energy, and its Δ₂ oscillates by O(h²) ≫ 1e−8 around it without the orbit
    leaving its side.)
    """
    model = model or SimpleBodyModel(INERTIA)
    integrator = integrator or dynamics_integrator(name)
    q, omega, t = Q0, MOMENTUM / INERTIA, 0.0
    flips, crossed, largest_delta2 = [], False, -np.inf
    while len(flips) < FLIPS and t < 420.0:
        q1, omega1 = integrator.integrate(q, omega, t, h, CHUNK, model)
        crossed |= bool(omega1[0] <= 0.0)
        largest_delta2 = max(largest_delta2, torque_free_invariants(INERTIA, INERTIA * omega1)[1])
        if np.sign(omega1[1]) != np.sign(omega[1]) or omega[1] == 0.0:
            for _ in range(CHUNK):  # find the step with the sign change, then the zero
                q2, omega2 = integrator.step(q, omega, t, h, model)
                if np.sign(omega2[1]) != np.sign(omega[1]) and omega[1] != 0.0:
                    flips.append(t + brentq(
                        lambda s: integrator.step(q, omega, t, s, model)[1][1], 0.0, h,
                        xtol=1e-13))
                q, omega, t = q2, omega2, t + h
            q1, omega1 = q, omega
        else:
            t += CHUNK * h
        q, omega = q1, omega1
    return np.array(flips), crossed, largest_delta2


@pytest.mark.parametrize('name, h, bound', [
    # Order 4: RK4 (and RKMK4, whose m is the same RK4) 3.6e−5 s at h = 0.1 (4.8e−5 s
    # with another flip definition), 2.7e−6 s at h = 0.05.
    ('rk4', 0.1, 5e-5), ('rk4', 0.05, 5e-5 / 10), ('rkmk4', 0.1, 5e-5),
    # Order 4 composition of Strang: 1.8e−3 s at 0.1, 1.3e−4 s at 0.05.
    ('yoshida4', 0.1, 2.5e-3), ('yoshida4', 0.05, 2.5e-3 / 10),
    # Order 2: 0.17 s at 0.1, 0.043 s at 0.05; 0.70 s at 0.2 (0.7 s with another flip definition).
    ('strang', 0.2, 1.0), ('strang', 0.1, 0.25), ('strang', 0.05, 0.25 / 3.5),
    # Method error far below the round-off floor (orders 6, 8, adaptive rtol 1e−9, exact):
    # 734..3670 steps leave δΔ₂/|Δ₂| of a few 1e−6 → 1e−6..7e−5 s (measured 2.0e−5, 4.0e−5,
    # 3.9e−6, 1.5e−6 s); floor bound 1e−4 s.
    ('casimir6', 0.1, 1e-4), ('casimir8', 0.1, 1e-4), ('dopri45', 0.1, 1e-4),
    ('exact', 0.5, 1e-4),
])
def test_flip_times_within_the_method_bound(name, h, bound):
    flips, crossed, _ = numerical_flips(name, h)
    assert not crossed
    assert flips.size == FLIPS
    errors = np.abs(flips - EXACT_FLIPS)
    assert np.max(errors) <= bound


@pytest.mark.parametrize('name, order', [('rk4', 4), ('yoshida4', 4), ('strang', 2)])
def test_flip_time_error_falls_with_the_method_order(name, order):
    # Halving the step divides the error after 10 flips by about 2^p (measured 13.5, 13.1,
    # 4.0): the flip error is the method's, not the detection's.
    coarse = np.max(np.abs(numerical_flips(name, 0.1)[0] - EXACT_FLIPS))
    fine = np.max(np.abs(numerical_flips(name, 0.05)[0] - EXACT_FLIPS))
    assert coarse / fine >= 0.8 * 2 ** order


def test_dzhanibekov_scene_default_never_crosses_the_separatrix():
    # The scene's own method and step (RK4, 1 ms; 3.5e5 steps for 10 flips). RK4's error at
    # 1 ms is ~1e−13 s; what is left is the round-off floor: √N·ε-sized relative errors in
    # G² and T, amplified by 1/|Δ₂| = 1e8: measured 1.1e−5 s after 10 flips (the scene's
    # description promised 1e−9 s, which round-off does not allow). Bound 1e−4 s.
    scene = load_scene('dzhanibekov')
    propagator = DynamicsPropagator(scene)
    np.testing.assert_array_equal(scene.initial_omega_body * INERTIA, MOMENTUM)
    np.testing.assert_array_equal(scene.inertia.tensor, np.diag(INERTIA))
    flips, crossed, largest_delta2 = numerical_flips(
        scene.integrator, scene.step, model=propagator.model, integrator=propagator.integrator)
    assert not crossed
    assert largest_delta2 < 0.0  # RK4 at 1 ms: Δ₂ itself never leaves the starting side
    assert flips.size == FLIPS
    assert np.max(np.abs(flips - EXACT_FLIPS)) <= 1e-4


def test_exact_flip_period():
    # Consecutive flips are 2K/|λ| apart: |λ| = √(Δ₃(J₁ − J₂)/(J₁J₂J₃)) = 1/√3, K from the
    # complementary parameter 1 − k² = Δ₂(J₃ − J₁)/(Δ₃(J₂ − J₁)) = 1e−8 (Landau & Lifshitz 1976,
    # §37).
    d1, d2, d3 = torque_free_invariants(INERTIA, MOMENTUM)
    rate = np.sqrt(d3 * (INERTIA[0] - INERTIA[1]) / np.prod(INERTIA))
    period = 2.0 * ellipkm1(d2 * (INERTIA[2] - INERTIA[0]) / (d3 * (INERTIA[1] - INERTIA[0])))
    np.testing.assert_allclose(np.diff(EXACT_FLIPS), period / rate, rtol=1e-12)
    assert d2 == pytest.approx(-1e-8, rel=1e-12)
