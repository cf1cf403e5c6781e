"""Hard case 5 in the core: rotations near π and the sign of q (docs/hard-cases.md §5).

What breaks naively: log via acos(w) or asin(|v|) loses half the digits near 0 and π;
w = ½√(1 + trace R) from a matrix cancels to nothing near π; an attitude error via
acos(p·q) or without |·| on the scalar part is wrong near π or depends on the sign of q; a
published stream renormalised without regard to the previous output flips between q and −q.

Bounds held here: log, the matrix round trip and the attitude error are accurate to a few ε
right up to and across π (compared with 40-digit mpmath values of the same double inputs);
every conversion is continuous in the attitude; q and −q give identical errors; and the
published stream (:class:`OutputTracker`) keeps q · q_prev ≥ 0 over 10⁵ random outputs. The
node's own stream is checked in test_hard_node_timing.py.
"""

import math

import mpmath
import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.session.outputs import OutputTracker
from rigid_body_attitude.core.propagator import GyroPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene

mpmath.mp.dps = 40
EPS = np.finfo(float).eps
OFFSETS = [1e-1, 1e-4, 1e-8, 1e-12, 1e-15, 0.0]  # π − angle


def random_axes(count, seed):
    """Unit vectors uniform on the sphere."""
    axes = np.random.default_rng(seed).normal(size=(count, 3))
    return axes / np.linalg.norm(axes, axis=1, keepdims=True)


def mp_log(q):
    """Rotation vector of the double quaternion ``q`` (w ≥ 0 representative), 40 digits."""
    qm = [mpmath.mpf(float(c)) for c in q]
    if qm[0] < 0:
        qm = [-c for c in qm]
    s = mpmath.sqrt(sum(c * c for c in qm[1:]))
    return [c * 2 * mpmath.atan2(s, qm[0]) / s for c in qm[1:]]


@pytest.mark.parametrize('offset', OFFSETS)
def test_log_near_pi_matches_50_digit_values(offset):
    worst = 0.0
    for axis in random_axes(50, seed=51):
        q = quat.exp((math.pi - offset) * axis)
        got = quat.log(q)
        reference = mp_log(q)
        worst = max(worst, max(abs(float(mpmath.mpf(float(g)) - r))
                               for g, r in zip(got, reference)))
    # atan2(|v|, w) is well conditioned at w → 0; the result (|v| ≈ π) carries the rounding
    # of atan2, a division and a product: ≤ 3 ulps of π ≈ 1.3e−15.
    assert worst <= 3.0 * math.pi * EPS


@pytest.mark.parametrize('offset', OFFSETS + [-1e-15, -1e-12, -1e-8, -1e-4])
def test_exp_log_round_trip_across_pi(offset):
    # Past π the rotation vector wraps to the other side (angle 2π − a, axis −e): the
    # attitude comes back to a few ε, whichever representative log picked.
    for axis in random_axes(50, seed=52):
        q = quat.exp((math.pi - offset) * axis)
        back = quat.exp(quat.log(q))
        assert quat.attitude_error(q, back) <= 8.0 * EPS
        assert np.linalg.norm(quat.log(q)) <= math.pi * (1.0 + 2.0 * EPS)


@pytest.mark.parametrize('offset', OFFSETS)
def test_matrix_round_trip_near_pi(offset):
    # Shepperd's choice of the largest pivot keeps from_matrix accurate where ½√(1 + trace)
    # would cancel (trace → −1 at π).
    for axis in random_axes(50, seed=53):
        q = quat.exp((math.pi - offset) * axis)
        back = quat.from_matrix(quat.to_matrix(q))
        assert quat.attitude_error(q, back) <= 8.0 * EPS
        assert back[0] >= 0.0  # the canonical representative


def test_attitude_error_is_continuous_through_pi_and_sign_invariant():
    # attitude_error(p, p ⊗ exp(a e)) = a for a ≤ π and 2π − a beyond, in 40-digit terms;
    # near π the atan2 form keeps full accuracy where acos(|p·q|) would lose half the digits.
    p = quat.normalize([0.8, -0.2, 0.3, 0.4])
    axis = random_axes(1, seed=54)[0]
    angles = np.concatenate([math.pi + np.array([-1e-3, -1e-6, -1e-9, -1e-12, -4e-16, 0.0,
                                                 4e-16, 1e-12, 1e-9, 1e-6, 1e-3]),
                             np.linspace(0.0, 2.0 * math.pi, 101)])
    for angle in angles:
        q = quat.multiply(p, quat.exp(angle * axis))
        expected = angle if angle <= math.pi else 2.0 * math.pi - angle
        error = quat.attitude_error(p, q)
        assert error == pytest.approx(expected, abs=8.0 * EPS)
        assert quat.attitude_error(p, -q) == error
        assert quat.attitude_error(-p, q) == error
        assert quat.attitude_error(q, p) == pytest.approx(error, abs=4.0 * EPS)


def test_continuous_and_canonical_choose_the_sign_only():
    rng = np.random.default_rng(55)
    q = quat.normalize(rng.normal(size=(1000, 4)))
    previous = quat.normalize(rng.normal(size=(1000, 4)))
    chosen = quat.continuous(q, previous)
    assert np.all(np.sum(chosen * previous, axis=1) >= 0.0)
    assert np.all((chosen == q).all(axis=1) | (chosen == -q).all(axis=1))
    canonical = quat.canonical(q)
    assert np.all(canonical[:, 0] >= 0.0)
    assert np.all((canonical == q).all(axis=1) | (canonical == -q).all(axis=1))


def test_published_stream_never_flips_over_a_hundred_thousand_random_outputs():
    # The tracker the node and the replay tool publish through, fed a gyro scene whose
    # attitude takes random steps of up to 3 rad and whose stored quaternion is replaced by
    # its negative at random (the same attitude: what a re-initialisation, a reset or a
    # canonicalising method may hand over). The published stream must pick the side of the
    # previous output every time.
    propagator = GyroPropagator(load_scene('strapdown'))
    tracker = OutputTracker()
    rng = np.random.default_rng(56)
    steps = rng.normal(size=(100_000, 3))
    steps *= (rng.uniform(0.0, 3.0, size=100_000) / np.linalg.norm(steps, axis=1))[:, None]
    signs = rng.choice([-1.0, 1.0], size=100_000)
    propagator.start(0.0, (0.0, 0.0, 0.0))
    previous = previous_raw = None
    worst_norm, raw_flips = 0.0, 0
    for k, (rate, sign) in enumerate(zip(steps, signs), start=1):
        propagator.update(float(k), rate)  # dt = 1 s: the step is the held rate vector
        propagator.state.attitude = sign * propagator.state.attitude
        raw = propagator.state.attitude
        published = np.array(tracker.attitude(propagator))
        assert quat.attitude_error(published, raw) <= 2.0 * EPS  # same attitude
        if previous is not None:
            assert published @ previous >= 0.0
            raw_flips += int(raw @ previous_raw < 0.0)
        worst_norm = max(worst_norm, abs(np.linalg.norm(published) - 1.0))
        previous, previous_raw = published, raw
    assert worst_norm <= 1e-12
    assert raw_flips >= 40_000  # the raw stream flips about half the time; the output never
